// State estimation for the servo loop (docs/estimation.md): the floating-base state the
// controllers need, from what HyQ measures, with a model of its own uncertainty.
//
//  - the filter: BaseEkf, an error-state EKF on position, velocity, orientation and the IMU's
//    gyro and accelerometer biases, predicted by the IMU every cycle (the accelerometer moved to
//    the base origin: f_B = R_BI f_I − α × p_BI − ω × (ω × p_BI), α from the gyro's difference);
//  - contact: ContactDetector per foot, a probability from the foot's load (not the schedule),
//    the foot's noise inflated for a window after each touchdown;
//  - legs: every foot in contact says the base moves so that its contact point stands still,
//      0 = v_W + R (ω × c_B + J q̇ + (Jw q̇) × (c_B − p_F)),  c_B = p_F − r Rᵀ ẑ,
//    (leg kinematics; a foot rolls on its sphere without slipping, so the contact point, not
//    the sphere's centre, is still), with σ = leg_velocity_noise · touchdown scale / √P(contact);
//    a foot whose innovation's squared Mahalanobis distance exceeds the gate is rejected that
//    cycle (slipping, bouncing) and counted. Gating uses the prediction, before any foot of the
//    cycle corrects it, so that a slipping foot cannot move the gate of the others; if every
//    foot in contact has been rejected for max_gated_s the prediction, not the feet, is wrong:
//    the foot nearest it passes each cycle until feet pass the gate again;
//  - height: each accepted foot's contact point is on the ground (z = ground_height_m, flat);
//  - standing still (every joint slower than still_joint_speed, the bias-corrected gyro below
//    still_gyro, both low-passed against sensor noise, for still_time_s): the base's velocity
//    and angular rate are zero, which makes
//    the gyro bias observable (yaw's included); the biases are estimated only then and held
//    while the robot moves, where impacts and slips would pull them;
//  - out: q, v (docs/conventions.md: v_W, ω_B = gyro − bias), the standard deviations, per foot
//    the contact probability, whether it corrected the filter, its rejections.
//
// Never allocates or throws after construction.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Dense>

#include "dynamics/leg_kinematics.h"
#include "dynamics/model.h"
#include "hal/config_key.h"
#include "hal/process_image.h"
#include "servo/common/servo_types.h"
#include "servo/estimation/base_ekf.h"
#include "servo/estimation/contact_detector.h"

namespace hyq::servo {

struct EstimatorConfig {
  ContactDetectorConfig contact;
  BaseEkfProcessNoise process;
  double leg_velocity_noise_m_s = 0.01;  // σ of a settled stance foot's velocity measurement
  double firm_contact_force_N = 150.0;   // below this load a foot's σ grows as this / load
  double height_noise_m = 0.01;          // σ of a stance foot's height above the ground
  double ground_height_m = 0.0;          // the (flat) ground's height in W
  double gate_chi2 = 16.27;              // χ²₃ at 0.999: a foot further from the prediction is rejected
  double max_gated_s = 0.2;              // every foot in contact rejected this long: the nearest passes
  double min_contact_probability = 0.5;  // a foot less likely in contact is not used
  double lift_speed_m_s = 0.05;          // a contact point rising or falling faster lifts or bounces
  double max_slip_speed_m_s = 0.5;       // ... or moving faster: a foot in the air, whatever its load says
  double still_joint_speed_rad_s = 0.05; // standing still: every joint slower than this ...
  double still_gyro_rad_s = 0.03;        // ... the corrected gyro below this ...
  double still_time_s = 0.2;             // ... for this long (both low-passed over still_filter_s)
  double still_filter_s = 0.05;          // time constant of the stillness test's low-pass (sensor noise)
  double still_velocity_noise_m_s = 0.005;  // σ of "the base is still" (v = 0)
  double still_rate_noise_rad_s = 0.002;    // σ of "the base does not turn" (ω = 0)
  double initial_velocity_m_s = 0.1;     // σ at start
  double initial_tilt_rad = 0.05;
  double initial_yaw_rad = 0.01;         // yaw starts at 0 by definition
  double initial_gyro_bias_rad_s = 0.01;
  double initial_accel_bias_m_s2 = 0.1;

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("contact_force_N", &contact.force_N).In(0.0, 2000.0).Unit("N")
                 .Doc("a foot's contact probability is ½ at this vertical load"));
    a->Visit(hal::Key("contact_force_width_N", &contact.width_N).In(0.1, 1000.0).Unit("N")
                 .Doc("width of the logistic contact probability"));
    a->Visit(hal::Key("touchdown_window_s", &contact.touchdown_window_s).In(0.0, 1.0).Unit("s")
                 .Doc("a foot's velocity is distrusted for this long after touchdown ..."));
    a->Visit(hal::Key("touchdown_noise_scale", &contact.touchdown_noise_scale).In(1.0, 1000.0)
                 .Doc("... by this factor on its σ at first, falling to 1"));
    a->Visit(hal::Key("gyro_noise_rad_s_sqrt_hz", &process.gyro_rad_s_sqrt_hz).In(1e-7, 1.0)
                 .Unit("rad/s/√Hz").Doc("process noise: the gyro's white noise"));
    a->Visit(hal::Key("accel_noise_m_s2_sqrt_hz", &process.accel_m_s2_sqrt_hz).In(1e-6, 10.0)
                 .Unit("m/s²/√Hz").Doc("process noise: the accelerometer's, with unmodelled accelerations"));
    a->Visit(hal::Key("gyro_bias_walk_rad_s2_sqrt_hz", &process.gyro_bias_rad_s2_sqrt_hz)
                 .In(0.0, 1.0).Unit("rad/s²/√Hz").Doc("random walk of the gyro bias"));
    a->Visit(hal::Key("accel_bias_walk_m_s3_sqrt_hz", &process.accel_bias_m_s3_sqrt_hz)
                 .In(0.0, 10.0).Unit("m/s³/√Hz").Doc("random walk of the accelerometer bias"));
    a->Visit(hal::Key("leg_velocity_noise_m_s", &leg_velocity_noise_m_s).In(1e-5, 10.0).Unit("m/s")
                 .Doc("σ of a settled stance foot's velocity measurement"));
    a->Visit(hal::Key("firm_contact_force_N", &firm_contact_force_N).In(0.0, 5000.0).Unit("N")
                 .Doc("below this vertical load a foot's σ grows as this / load (it slides first)"));
    a->Visit(hal::Key("height_noise_m", &height_noise_m).In(1e-5, 1.0).Unit("m")
                 .Doc("σ of a stance foot's height above the ground"));
    a->Visit(hal::Key("ground_height_m", &ground_height_m).In(-100.0, 100.0).Unit("m")
                 .Doc("the flat ground's height in the world frame"));
    a->Visit(hal::Key("gate_chi2", &gate_chi2).In(0.1, 1e6)
                 .Doc("a foot's squared Mahalanobis distance above this: rejected (χ²₃ 0.999 = 16.27)"));
    a->Visit(hal::Key("max_gated_s", &max_gated_s).In(0.0, 10.0).Unit("s")
                 .Doc("every foot in contact rejected this long: the one nearest the prediction passes"));
    a->Visit(hal::Key("min_contact_probability", &min_contact_probability).In(0.0, 1.0)
                 .Doc("a foot less likely in contact corrects nothing"));
    a->Visit(hal::Key("lift_speed_m_s", &lift_speed_m_s).In(0.0, 10.0).Unit("m/s")
                 .Doc("a contact point moving up or down faster lifts off or bounces: its motion is no slip evidence"));
    a->Visit(hal::Key("max_slip_speed_m_s", &max_slip_speed_m_s).In(0.0, 100.0).Unit("m/s")
                 .Doc("a contact point moving faster is in the air (a swing's torques read as load): no slip evidence"));
    a->Visit(hal::Key("still_joint_speed_rad_s", &still_joint_speed_rad_s).In(0.0, 10.0).Unit("rad/s")
                 .Doc("standing still: every joint slower than this ..."));
    a->Visit(hal::Key("still_gyro_rad_s", &still_gyro_rad_s).In(0.0, 10.0).Unit("rad/s")
                 .Doc("... the bias-corrected gyro below this ..."));
    a->Visit(hal::Key("still_time_s", &still_time_s).In(0.0, 60.0).Unit("s").Doc("... for this long"));
    a->Visit(hal::Key("still_filter_s", &still_filter_s).In(0.0, 10.0).Unit("s")
                 .Doc("the joint rates and the gyro are low-passed with this time constant before the stillness test"));
    a->Visit(hal::Key("still_velocity_noise_m_s", &still_velocity_noise_m_s).In(1e-6, 1.0).Unit("m/s")
                 .Doc("σ of \"the base is still\""));
    a->Visit(hal::Key("still_rate_noise_rad_s", &still_rate_noise_rad_s).In(1e-7, 1.0).Unit("rad/s")
                 .Doc("σ of \"the base does not turn\""));
    a->Visit(hal::Key("initial_velocity_m_s", &initial_velocity_m_s).In(1e-6, 10.0).Unit("m/s")
                 .Doc("σ of the velocity at start"));
    a->Visit(hal::Key("initial_tilt_rad", &initial_tilt_rad).In(1e-6, 1.0).Unit("rad")
                 .Doc("σ of roll and pitch at start"));
    a->Visit(hal::Key("initial_yaw_rad", &initial_yaw_rad).In(1e-6, 3.2).Unit("rad")
                 .Doc("σ of yaw at start (yaw starts at 0)"));
    a->Visit(hal::Key("initial_gyro_bias_rad_s", &initial_gyro_bias_rad_s).In(1e-7, 1.0).Unit("rad/s")
                 .Doc("σ of the gyro bias at start"));
    a->Visit(hal::Key("initial_accel_bias_m_s2", &initial_accel_bias_m_s2).In(1e-6, 10.0).Unit("m/s²")
                 .Doc("σ of the accelerometer bias at start"));
    const char* kExpected = "the error-state EKF's keys (docs/estimation.md)";
    a->Visit(hal::RetiredKey{"stance_force_N", "contact_force_N (the contact probability's centre)",
                             "the complementary filter's stance threshold"});
    a->Visit(hal::RetiredKey{"tilt_correction_gain", kExpected, "the complementary filter's gain"});
    a->Visit(hal::RetiredKey{"velocity_blend", kExpected, "the complementary filter's gain"});
    a->Visit(hal::RetiredKey{"imu_gravity_window_m_s2", kExpected, "the complementary filter's window"});
  }
};

enum class [[nodiscard]] EstimatorStatus : std::uint8_t {
  kOk,
  kNoImu,        // no valid IMU reading yet: the orientation is unknown
  kNoJointData,  // a joint has never delivered a value (NaN)
  kNonFinite,    // the estimate became non-finite (inputs are checked first, so: a bug)
};
const char* ToString(EstimatorStatus s) noexcept;

/// What the filter made of one foot this cycle.
struct FootEstimate {
  double contact_probability = 0.0;
  bool settling = false;     // within the window after its touchdown
  bool used = false;         // its kinematics corrected the filter
  bool rejected = false;     // in contact, but its velocity failed the gate
  double mahalanobis_sq = 0.0;   // of its velocity innovation (0 when not in contact)
  // its contact point's velocity (W) by its kinematics and the predicted base state: what the
  // foot moves at if the prediction is right (0 when not in contact)
  Eigen::Vector3d contact_velocity_W = Eigen::Vector3d::Zero();
  // the same, whatever the contact: a foot that carries load but moves is not on the ground (the
  // load is the torques': a foot in the air pushed down by its leg reads as loaded)
  Eigen::Vector3d point_velocity_W = Eigen::Vector3d::Zero();
  std::int64_t rejections = 0;   // cycles rejected since the last Reset
  std::int64_t touchdowns = 0;
};

class StateEstimator {
 public:
  StateEstimator(const dynamics::Model& model, const EstimatorConfig& settings, double dt);

  /// Forgets everything (the next valid IMU reading initialises the orientation from gravity).
  void Reset() noexcept;

  /// One cycle: joint and IMU inputs of the process image (the last valid values), the stance
  /// the gait schedule expects now (used only for the controllers' stance(), never by the filter).
  EstimatorStatus Update(const hal::ProcessImage& image,
                         const std::array<bool, kNumFeet>& stance_schedule) noexcept;

  /// What a fault's stop must do without, from the next Update on (servo/runtime/stop_class.h):
  /// a lost joint reads its last finite angle, at rest, with no torque, and its leg's foot is
  /// no contact; without the IMU the filter predicts the base unaccelerated and not rotating,
  /// the legs' kinematics correcting it (a sit-down's worth of time). Nothing lost: the default.
  void DoWithout(const LostInputs& lost) noexcept { lost_ = lost; }

  /// Generalised coordinates and velocities (docs/conventions.md).
  const VectorQ& q() const noexcept { return q_; }
  const VectorV& v() const noexcept { return v_; }
  /// The controllers' stance: scheduled and in contact (the schedule alone when no foot is both).
  const std::array<bool, kNumFeet>& stance() const noexcept { return stance_; }
  /// Estimated vertical load on each foot, N (world z, + = pushing the robot up).
  const std::array<double, kNumFeet>& foot_load_N() const noexcept { return load_; }
  const std::array<FootEstimate, kNumFeet>& feet() const noexcept { return feet_; }
  /// Per foot: the base velocity against which this foot's slip is measured is anchored by
  /// another foot the filter accepted, and the foot is in contact, settled and neither lifting
  /// off nor bouncing (its contact point neither rises nor falls, nor moves faster than a foot
  /// slides): its slip velocity is evidence (the friction estimator's mask).
  const std::array<bool, kNumFeet>& slip_evidence() const noexcept { return slip_evidence_; }
  Eigen::Matrix3d R_WB() const noexcept { return ekf_.R_WB(); }
  /// Standard deviations: position and velocity (W), orientation about W's axes (roll, pitch,
  /// yaw for small tilts).
  Eigen::Vector3d position_std_m() const noexcept;
  Eigen::Vector3d velocity_std_m_s() const noexcept;
  Eigen::Vector3d orientation_std_rad() const noexcept;
  const Eigen::Vector3d& gyro_bias_rad_s() const noexcept { return ekf_.gyro_bias(); }
  const Eigen::Vector3d& accel_bias_m_s2() const noexcept { return ekf_.accel_bias(); }
  bool still() const noexcept { return still_s_ >= settings_.still_time_s; }
  bool initialised() const noexcept { return initialised_; }
  const BaseEkf& filter() const noexcept { return ekf_; }

 private:
  void CorrectWithFeet(const VectorJ& qdj, const Eigen::Vector3d& w_B) noexcept;

  const dynamics::Model& model_;
  LostInputs lost_;
  std::array<bool, kNumFeet> stale_{};  // a joint of the leg is held this cycle (its input late)
  EstimatorConfig settings_;
  double dt_;
  dynamics::LegKinematics legs_;
  Eigen::Matrix3d R_BI_;            // IMU frame → base frame
  Eigen::Vector3d p_BI_;            // IMU origin in the base frame
  BaseEkf ekf_;
  bool initialised_ = false;
  double still_s_ = 0.0;
  double all_rejected_s_ = 0.0;
  Eigen::Vector3d previous_gyro_B_ = Eigen::Vector3d::Zero();
  VectorJ qd_lowpass_ = VectorJ::Zero();        // for the stillness test
  Eigen::Vector3d w_lowpass_ = Eigen::Vector3d::Zero();
  bool have_previous_gyro_ = false;
  std::array<ContactDetector, kNumFeet> contacts_;
  std::array<FootEstimate, kNumFeet> feet_{};
  std::array<bool, kNumFeet> slip_evidence_{};
  // per foot, this cycle: sphere centre, its Jacobians (base frame)
  std::array<Eigen::Vector3d, kNumFeet> p_BF_;
  std::array<Eigen::Matrix3d, kNumFeet> J_, Jw_;
  VectorQ q_ = VectorQ::Zero();
  VectorV v_ = VectorV::Zero();
  std::array<bool, kNumFeet> stance_{};
  std::array<double, kNumFeet> load_{};
};

}  // namespace hyq::servo
