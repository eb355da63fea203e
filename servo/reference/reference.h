// Motion references: the base trajectory, the feet (planted or swinging) and, through leg
// inverse kinematics, joint references q_ref, q̇_ref, q̈_ref that are consistent with each other
// (q̇_ref = d/dt q_ref, q̈_ref = d/dt q̇_ref; tests/servo/reference_test.cc checks by finite
// differences), plus the stance flags of the gait schedule.
//
//   stand:        the standing posture, optionally reached from a lower base height
//   trot:         diagonal pairs (lf+rh, rf+lh) in antiphase, Barasuol et al., "A reactive
//                 controller framework for quadrupedal locomotion on challenging terrain",
//                 ICRA 2013: step frequency, step height, stride length, duty factor
//   figure_eight: the body traces a figure eight in the horizontal plane, all feet planted
#pragma once

#include <array>
#include <memory>
#include <string>

#include "dynamics/leg_kinematics.h"
#include "servo/control/controller.h"

namespace hyq::servo {

/// The base's desired motion (world frame; angular quantities in the base frame).
struct BaseReference {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
  double yaw = 0.0;  // heading; roll and pitch are zero in these references
  double yaw_rate = 0.0;
  double yaw_acc = 0.0;
};

struct FootReference {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  // foot sphere centre
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();
  bool stance = true;
};

struct ReferenceSample {
  BaseReference base;
  std::array<FootReference, kNumFeet> feet;
  JointReference joints;  // q, q̇, q̈ (12) and the stance flags
  dynamics::IkStatus ik = dynamics::IkStatus::kOk;
};

struct TrotParams {
  double step_frequency_Hz = 1.4;  // gait cycles per second
  double step_height_m = 0.08;
  double stride_m = 0.14;          // forward distance per gait cycle (speed = stride × frequency)
  double duty_factor = 0.6;        // fraction of the cycle a foot is in stance (0.5 .. 0.95)
  double start_delay_s = 0.5;      // stand still first
  double ramp_s = 1.0;             // speed ramps up smoothly over this time
};

struct FigureEightParams {
  double period_s = 4.0;           // one figure eight
  double amplitude_x_m = 0.06;     // forward-backward
  double amplitude_y_m = 0.04;     // sideways
  double start_delay_s = 0.5;
  double ramp_s = 0.5;             // amplitude envelope
};

class Reference {
 public:
  enum class Kind { kStand, kTrot, kFigureEight };

  /// Stand at the model's standing posture, base height `height_m` (0: the model's).
  static Reference Stand(const dynamics::Model& model, double height_m = 0.0);
  static Reference Trot(const dynamics::Model& model, const TrotParams& p, double height_m = 0.0);
  static Reference FigureEight(const dynamics::Model& model, const FigureEightParams& p,
                               double height_m = 0.0);

  /// The reference at time t (s). The leg IK starts from the previous sample's angles, so call
  /// it with increasing t as a loop does (any t works; the first call starts from standing).
  /// Never allocates.
  void Sample(double t, ReferenceSample* out) noexcept;

  Kind kind() const noexcept { return kind_; }
  /// Feet positions of the standing posture relative to the base, base frame.
  const std::array<Eigen::Vector3d, kNumFeet>& nominal_feet_B() const noexcept { return nominal_; }

 private:
  Reference(const dynamics::Model& model, Kind kind, double height_m);
  void SampleBase(double t, BaseReference* b) const noexcept;
  void SampleFeet(double t, ReferenceSample* s) const noexcept;
  Eigen::Vector3d FootHold(int leg, double t) const noexcept;  // where a stance foot sits

  const dynamics::Model* model_;
  dynamics::LegKinematics legs_;
  Kind kind_;
  double height_m_;
  TrotParams trot_;
  FigureEightParams eight_;
  std::array<Eigen::Vector3d, kNumFeet> nominal_;  // base frame, standing posture
  dynamics::VectorJ last_q_;
};

}  // namespace hyq::servo
