// State estimation for the servo loop (docs/servo.md, "State estimation"): the floating-base
// state the controllers need, from what HyQ measures.
//
//  - orientation: the IMU's gyro integrated on SO(3) (R ← R exp([ω_B dt]×)), its tilt pulled
//    towards the accelerometer's "up" with gain k when |a| ≈ g (a complementary filter in the
//    style of Mahony et al.: ω_B += k (up_measured × up_predicted)); yaw is unobservable and
//    drifts with the gyro bias.
//  - angular velocity: the gyro, rotated into the base frame.
//  - linear velocity: each stance foot is assumed still, so the base moves at
//    v_W = −R (ω_B × p_BF_B + J_leg q̇_leg) for it (leg kinematics); the mean over the stance feet
//    corrects a prediction from the accelerometer, v ← v + (R f_B + g) dt, with weight α per cycle.
//  - height: the stance feet's sphere centres are at the foot radius above the ground (z = 0);
//    x and y integrate v (they drift; nothing in the loop uses them but the telemetry).
//  - stance: a foot is in stance when the gait schedule says so AND its load, estimated from the
//    leg's measured joint torques through the leg Jacobian (F = −J⁻ᵀ τ, massless leg), exceeds a
//    threshold; the schedule alone when no foot passes both.
//
// Never allocates or throws after construction.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Dense>

#include "dynamics/leg_kinematics.h"
#include "dynamics/model.h"
#include "hal/process_image.h"
#include "servo/common/servo_types.h"

namespace hyq::servo {

struct EstimatorConfig {
  double stance_force_N = 60.0;         // a scheduled-stance foot carries at least this
  double tilt_correction_gain = 0.5;    // 1/s, accelerometer tilt correction (complementary)
  double velocity_blend = 0.1;          // per cycle: weight of the kinematic velocity vs IMU
  double imu_gravity_window_m_s2 = 1.5; // use the accelerometer for tilt when |a| ≈ g ± this

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("stance_force_N", &stance_force_N).In(0.0, 2000.0).Unit("N")
                 .Doc("a scheduled-stance foot carries at least this"));
    a->Visit(hal::Key("tilt_correction_gain", &tilt_correction_gain).In(0.0, 100.0).Unit("1/s")
                 .Doc("accelerometer tilt correction (complementary filter)"));
    a->Visit(hal::Key("velocity_blend", &velocity_blend).In(0.0, 1.0)
                 .Doc("per cycle: weight of the kinematic velocity against the IMU's"));
    a->Visit(hal::Key("imu_gravity_window_m_s2", &imu_gravity_window_m_s2).In(0.0, 9.81)
                 .Unit("m/s²").Doc("the accelerometer corrects tilt when |a| ≈ g ± this"));
  }
};

enum class [[nodiscard]] EstimatorStatus : std::uint8_t {
  kOk,
  kNoImu,        // no valid IMU reading yet: the orientation is unknown
  kNoJointData,  // a joint has never delivered a value (NaN)
  kNonFinite,    // the estimate became non-finite (inputs are checked first, so: a bug)
};
const char* ToString(EstimatorStatus s) noexcept;

class StateEstimator {
 public:
  StateEstimator(const dynamics::Model& model, const EstimatorConfig& settings, double dt);

  /// Forgets everything (the next valid IMU reading initialises the orientation from gravity).
  void Reset() noexcept;

  /// One cycle: joint and IMU inputs of the process image (the last valid values), the stance
  /// the gait schedule expects now.
  EstimatorStatus Update(const hal::ProcessImage& image,
                         const std::array<bool, kNumFeet>& stance_schedule) noexcept;

  /// Generalised coordinates and velocities (docs/conventions.md).
  const VectorQ& q() const noexcept { return q_; }
  const VectorV& v() const noexcept { return v_; }
  const std::array<bool, kNumFeet>& stance() const noexcept { return stance_; }
  /// Estimated vertical load on each foot, N (world z, + = pushing the robot up).
  const std::array<double, kNumFeet>& foot_load_N() const noexcept { return load_; }
  Eigen::Matrix3d R_WB() const noexcept { return orientation_.toRotationMatrix(); }
  bool initialised() const noexcept { return initialised_; }

 private:
  const dynamics::Model& model_;
  EstimatorConfig settings_;
  double dt_;
  dynamics::LegKinematics legs_;
  Eigen::Matrix3d R_BI_;            // IMU frame → base frame
  Eigen::Quaterniond orientation_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W_ = Eigen::Vector3d::Zero();
  bool initialised_ = false;
  VectorQ q_ = VectorQ::Zero();
  VectorV v_ = VectorV::Zero();
  std::array<bool, kNumFeet> stance_{};
  std::array<double, kNumFeet> load_{};
};

}  // namespace hyq::servo
