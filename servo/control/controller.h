// One interface for every joint controller, so the controller is a choice in configuration:
// PID, the non-slipping floating-base ID (Mistry et al. 2010), Stage I only, and the two-stage
// ID (Zapolsky et al.). What each one adds to the reference (docs/inverse_dynamics.md, "Feedback"):
//
//   PID:        τ = PID(q_ref − q, q̇_ref − q̇)                       (PidGains, torque units)
//   PD + g:     τ = τ_g(q, v, stance) + PD(q_ref − q, q̇_ref − q̇)      (PdGains; pd_gravity.h)
//   ID kinds:   q̈_des = q̈_ref + Kp (q_ref − q) + Kd (q̇_ref − q̇)     (FeedbackGains, 1/s², 1/s)
//               τ = ID(q, v, q̈_des, stance, μ) + Kp_τ (q_ref − q) + Kd_τ (q̇_ref − q̇) + I
//               I ← clamp(I + Ki_τ (q_ref − q) dt, ±i_limit_τ)   (integral action against the
//               model's errors; not integrated while τ saturates along the error: anti-windup)
//
// The three ID controllers share the same q̈_des and the same optional PD torque, so their
// comparison is fair; the PD torque gains are zero unless configured.
#pragma once

#include <optional>
#include <string_view>

#include "servo/common/servo_types.h"
#include "servo/control/noslip_id.h"
#include "servo/control/pd_gravity.h"
#include "servo/control/pid_controller.h"
#include "servo/control/two_stage_id.h"

namespace hyq::servo {

struct FeedbackGains {
  dynamics::VectorJ kp_acc = dynamics::VectorJ::Zero();  // 1/s²
  dynamics::VectorJ kd_acc = dynamics::VectorJ::Zero();  // 1/s
  dynamics::VectorJ kp_tau = dynamics::VectorJ::Zero();  // N·m/rad (added PD torque)
  dynamics::VectorJ kd_tau = dynamics::VectorJ::Zero();  // N·m·s/rad
  dynamics::VectorJ ki_tau = dynamics::VectorJ::Zero();  // N·m/(rad·s) (integral torque)
  dynamics::VectorJ i_limit_tau = dynamics::VectorJ::Zero();  // N·m, bound on it
};

struct ControllerConfig {
  ControllerKind kind = ControllerKind::kTwoStageId;
  FeedbackGains feedback;
  PidGains pid;
  PdGains pd_gravity;  // kPdGravity's PD
  TwoStageSettings id;  // stage2 is forced off for kStage1Id
  // The feedback gains (kp, kd; not the integrals, not the feed-forward) on the joints of a leg
  // whose reference foot is in swing are multiplied by these (1: off), per controller, each
  // tuned for its own: the IDs' kp_tau/kd_tau, the PID's, PD + g's. A swing leg is light: the
  // gains that hold the trunk ring it behind the actuator's lag (docs/baselines.md).
  double swing_gain_scale = 1.0;      // no-slip, Stage I and two-stage ID
  double pid_swing_gain_scale = 1.0;  // PID
  double pdg_swing_gain_scale = 1.0;  // PD + gravity compensation

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("kind", &kind).Choices(ControllerKindChoices()).Doc("the joint controller"));
    // one value, 3 (haa, hfe, kfe of every leg) or 12 (lf rf lh rh)
    a->Section("gains", [this](auto* g) {
      g->Visit(hal::Key("kp_tau", &feedback.kp_tau).In(0, kMaxKpTau).Unit("N·m/rad")
                   .Doc("the IDs' PD torque added to the feed-forward"));
      g->Visit(hal::Key("kd_tau", &feedback.kd_tau).In(0, kMaxKdTau).Unit("N·m·s/rad")
                   .Doc("... its damping"));
      // q̈ feedback: discrete stability at the loop rate needs kd·dt < 1 and kp·dt² < 1
      g->Visit(hal::Key("kp_acc", &feedback.kp_acc).In(0, 0.25).MaxTimesRate(2).Unit("1/s²")
                   .Doc("the IDs' feedback in the desired accelerations"));
      g->Visit(hal::Key("kd_acc", &feedback.kd_acc).In(0, 0.5).MaxTimesRate(1).Unit("1/s")
                   .Doc("... its damping"));
      g->Visit(hal::Key("pid_kp", &pid.kp).In(0, kMaxKpTau).Unit("N·m/rad").Doc("the PID controller"));
      g->Visit(hal::Key("pid_ki", &pid.ki).In(0, kMaxKiTau).Unit("N·m/(rad·s)").Doc("the PID's integral"));
      g->Visit(hal::Key("pid_kd", &pid.kd).In(0, kMaxKdTau).Unit("N·m·s/rad").Doc("the PID's damping"));
      g->Visit(hal::Key("pid_i_limit", &pid.i_limit).In(0, 1000).Unit("N·m")
                   .Doc("bound on the PID's integral term"));
      g->Visit(hal::Key("pdg_kp", &pd_gravity.kp).In(0, kMaxKpTau).Unit("N·m/rad")
                   .Doc("PD + gravity compensation"));
      g->Visit(hal::Key("pdg_kd", &pd_gravity.kd).In(0, kMaxKdTau).Unit("N·m·s/rad")
                   .Doc("... its damping"));
      g->Visit(hal::Key("ki_tau", &feedback.ki_tau).In(0, kMaxKiTau).Unit("N·m/(rad·s)")
                   .Doc("integral torque added to the IDs' (against the model's errors)"));
      g->Visit(hal::Key("i_limit_tau", &feedback.i_limit_tau).In(0, 1000).Unit("N·m")
                   .Doc("bound on it"));
      g->Visit(hal::Key("swing_scale", &swing_gain_scale).In(0.05, 1.0)
                   .Doc("the IDs' kp_tau, kd_tau on a swing leg's joints × this (1: off)"));
      g->Visit(hal::Key("pid_swing_scale", &pid_swing_gain_scale).In(0.05, 1.0)
                   .Doc("the same for the PID's kp, kd"));
      g->Visit(hal::Key("pdg_swing_scale", &pdg_swing_gain_scale).In(0.05, 1.0)
                   .Doc("the same for PD + g's kp, kd"));
    });
    a->Visit("two_stage", &id);  // stage2 is forced off for the stage1 kind
  }
};

/// The joint reference of one cycle and the contact situation it assumes.
struct JointReference {
  dynamics::VectorJ q = dynamics::VectorJ::Zero();
  dynamics::VectorJ qd = dynamics::VectorJ::Zero();
  dynamics::VectorJ qdd = dynamics::VectorJ::Zero();
  std::array<bool, kNumFeet> stance{true, true, true, true};
  /// How far a stance foot has taken over (0 at its touchdown, 1 once the reference's load ramp
  /// has passed; servo/reference/reference.h, TouchdownParams::load_ramp_s): every controller
  /// blends the leg's feedback gains from the swing scale to 1 by it. A swing foot's is not used.
  std::array<double, kNumFeet> takeover{1.0, 1.0, 1.0, 1.0};
  /// The same over TouchdownParams::mu_ramp_s: the ID kinds give the foot this fraction of its μ
  /// in Stage I.
  std::array<double, kNumFeet> friction_takeover{1.0, 1.0, 1.0, 1.0};
};

struct ContactEnvironment {
  std::array<double, kNumFeet> mu{1.0, 1.0, 1.0, 1.0};
  std::array<Eigen::Vector3d, kNumFeet> normal_W{Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(),
                                                 Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()};
};

class Controller {
 public:
  /// Builds every controller kind up front (QP workspaces included), so switching at run time
  /// allocates nothing.
  Controller(const dynamics::Model& model, const ControllerConfig& config);

  /// One cycle: `dyn` = ComputeCycleDynamics(model, q, v). Fills out->tau_Nm (and, for the ID
  /// kinds, the impulses and stage reports). Never throws or allocates.
  IdStatus Compute(const dynamics::CycleDynamics& dyn, const VectorQ& q, const VectorV& v,
                   const JointReference& ref, const ContactEnvironment& env, double dt,
                   IdOutput* out) noexcept {
    return ComputeWithBias(dyn, dyn.bias, q, v, ref, env, dt, out);
  }
  /// As above, with the model corrected by an estimated trunk disturbance d_b (the base rows'
  /// generalized force the model does not explain; disturbance_observer.h): PD + g and the ID
  /// kinds use h − [d_b; 0] where they use the model's h. `dyn` itself is left as it is.
  IdStatus Compute(const dynamics::CycleDynamics& dyn, const dynamics::Vector6d& d_b,
                   const VectorQ& q, const VectorV& v, const JointReference& ref,
                   const ContactEnvironment& env, double dt, IdOutput* out) noexcept;

  /// The ID input of the last Compute (for recording ID problem files).
  const IdInput& last_input() const noexcept { return input_; }

  ControllerKind kind() const noexcept { return config_.kind; }
  void SetKind(ControllerKind kind) noexcept;
  /// Clears every controller's state (the integrals, warm starts): on each entry into ACTIVE.
  void Reset() noexcept;
  /// The ID kinds' integral torque I, N·m.
  const dynamics::VectorJ& id_integral() const noexcept { return id_integral_; }
  void SetFeedback(const FeedbackGains& g) noexcept { config_.feedback = g; }
  void SetPidGains(const PidGains& g) noexcept { pid_.set_gains(g); }
  void SetPdGravityGains(const PdGains& g) noexcept { pd_gravity_.set_gains(g); }
  const PdGravityController& pd_gravity() const noexcept { return pd_gravity_; }
  const ControllerConfig& config() const noexcept { return config_; }
  const FallbackCounters& two_stage_counters() const noexcept { return two_stage_.counters(); }
  const FallbackCounters& stage1_counters() const noexcept { return stage1_.counters(); }
  const FallbackCounters& noslip_counters() const noexcept { return noslip_.counters(); }
  const TwoStageId& two_stage() const noexcept { return two_stage_; }

 private:
  IdStatus ComputeWithBias(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h,
                           const VectorQ& q, const VectorV& v, const JointReference& ref,
                           const ContactEnvironment& env, double dt, IdOutput* out) noexcept;

  const dynamics::Model& model_;
  ControllerConfig config_;
  PidController pid_;
  PdGravityController pd_gravity_;
  NoSlipId noslip_;
  TwoStageId stage1_;
  TwoStageId two_stage_;
  IdInput input_;
  dynamics::VectorJ effort_limit_;
  dynamics::VectorJ id_integral_ = dynamics::VectorJ::Zero();
  dynamics::VectorV h_corrected_ = dynamics::VectorV::Zero();  // h − [d_b; 0], per cycle
};

}  // namespace hyq::servo
