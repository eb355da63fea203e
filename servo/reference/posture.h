// Stand up and sit down: a posture change with every foot on the ground. The base
// rises or sinks from h0 to h1 along a minimum-jerk profile at a fixed heading, braking from the
// horizontal velocity it had (a trot's) to rest within min(duration, 0.3 s), x(s) = v0 T (s − s³ + s⁴/2),
// s = t/T (the quintic with x(0) = 0, x'(0) = v0 T, x''(0) = x'(1) = x''(1) = 0); each
// foot keeps its place on the ground, and a foot still above the ground (a trot's swing foot
// when the stop came) is lowered onto it first. q_ref, q̇_ref, q̈_ref by the legs' inverse
// kinematics, consistent with each other (tests/servo/reference_test.cc, finite differences).
//
//   stand-up:  from the resting crouch the robot was in at enable to the standing height
//   sit-down:  from wherever the controlled stop found it to the crouch, then damping, 0 N·m
//
// Never allocates after construction.
#pragma once

#include <array>

#include "dynamics/leg_kinematics.h"
#include "servo/control/controller.h"

namespace hyq::servo {

class PostureMove {
 public:
  explicit PostureMove(const dynamics::Model& model);

  /// Starts a move to base height `h1_m` over `duration_s` from the measured joint angles `q`
  /// (feet relative to the base from the legs' kinematics, the base level). The start height is
  /// the one that puts the `on_ground` feet on the ground (their mean); the feet not on the
  /// ground are lowered onto it in the first `lower_fraction` of the move.
  /// `v0_B`: the base's horizontal velocity at the start (base frame, m/s), braked to rest in
  /// min(duration, 0.3 s). A fault's lost joint needs nothing of it: the lost board is off, its
  /// valve closed, the joint locked, and its leg carries as the others do (docs/servo.md,
  /// "Graded stops").
  void Start(const dynamics::VectorJ& q, const std::array<bool, kNumFeet>& on_ground, double h1_m,
             double duration_s, const Eigen::Vector2d& v0_B = Eigen::Vector2d::Zero(),
             double lower_fraction = 0.4) noexcept;

  /// The joint reference at `t` seconds into the move (t ≥ duration: the end posture, at rest);
  /// false when a leg's inverse kinematics did not solve (the previous sample stands).
  bool Sample(double t, JointReference* out) noexcept;

  double duration_s() const noexcept { return duration_s_; }
  /// The foot stood on the ground when the move began (else it is lowered onto it).
  bool starts_on_ground(std::size_t f) const noexcept { return on_ground_[f]; }
  double start_height_m() const noexcept { return h0_m_; }
  /// The base position of the last Sample, in the move's frame (origin under the base at the
  /// start, axes of the base's heading).
  const Eigen::Vector3d& base_position_m() const noexcept { return last_p_B_; }
  double end_height_m() const noexcept { return h1_m_; }

 private:
  const dynamics::Model& model_;
  dynamics::LegKinematics legs_;
  double h0_m_ = 0.0, h1_m_ = 0.0, duration_s_ = 1.0, lower_s_ = 0.4, brake_s_ = 0.5;
  Eigen::Vector2d v0_B_ = Eigen::Vector2d::Zero();
  std::array<Eigen::Vector3d, kNumFeet> p_WF0_{};  // feet at the start, base at (0, 0, h0)
  std::array<bool, kNumFeet> on_ground_{};
  dynamics::VectorJ last_q_ = dynamics::VectorJ::Zero();
  Eigen::Vector3d last_p_B_ = Eigen::Vector3d::Zero();
};

}  // namespace hyq::servo
