// PD + gravity compensation: the fourth baseline of the comparison (docs/experiments.md).
// It has a model-based feed-forward but no contact model: no friction cone, no contact
// accelerations, no impulses. It separates "any model-based feed-forward" from the two-stage
// ID's "contact-aware feed-forward".
//
// The feed-forward holds the measured posture statically: the model's bias forces h(q, v) (gravity
// and the small velocity terms) with the trunk's six rows carried by the reference's stance feet,
// their forces the least-norm solution (damped: two feet cannot carry a moment about the line
// between them):
//   Σ_f J_f,bᵀ f_f = h_b,   f_f = J_f,b y,   y = (Σ_f J_f,bᵀ J_f,b + λ I)⁻¹ h_b
//   τ_g = h_j − Σ_f J_f,jᵀ f_f
// and the PD on the joint errors:  τ = τ_g + Kp (q_ref − q) + Kd (q̇_ref − q̇), clamped to the
// joints' effort limits. With no stance foot τ_g = h_j (the legs' own weight).
#pragma once

#include <array>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/model.h"

namespace hyq::servo {

struct PdGains {
  dynamics::VectorJ kp = dynamics::VectorJ::Zero();  // N·m/rad
  dynamics::VectorJ kd = dynamics::VectorJ::Zero();  // N·m·s/rad
};

class PdGravityController {
 public:
  PdGravityController(const PdGains& gains, const dynamics::VectorJ& effort_limit_Nm);

  /// One cycle; `dyn` is the cycle's dynamics at the measured state, `h` the bias forces the
  /// feed-forward holds (dyn.bias, or that bias corrected by an estimated disturbance). Never
  /// allocates. `gain_scale` (optional): per joint, multiplies kp and kd (not τ_g).
  dynamics::VectorJ Compute(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h,
                            const dynamics::VectorJ& q, const dynamics::VectorJ& qd,
                            const dynamics::VectorJ& q_ref, const dynamics::VectorJ& qd_ref,
                            const std::array<bool, dynamics::kNumFeet>& stance,
                            const dynamics::VectorJ* gain_scale = nullptr) noexcept;
  /// As above with the model's h = dyn.bias.
  dynamics::VectorJ Compute(const dynamics::CycleDynamics& dyn, const dynamics::VectorJ& q,
                            const dynamics::VectorJ& qd, const dynamics::VectorJ& q_ref,
                            const dynamics::VectorJ& qd_ref,
                            const std::array<bool, dynamics::kNumFeet>& stance,
                            const dynamics::VectorJ* gain_scale = nullptr) noexcept {
    return Compute(dyn, dyn.bias, q, qd, q_ref, qd_ref, stance, gain_scale);
  }

  /// The last cycle's feed-forward τ_g, N·m.
  const dynamics::VectorJ& gravity_torque() const noexcept { return tau_g_; }
  void set_gains(const PdGains& g) noexcept { gains_ = g; }
  const PdGains& gains() const noexcept { return gains_; }

 private:
  PdGains gains_;
  dynamics::VectorJ effort_limit_;
  dynamics::VectorJ tau_g_ = dynamics::VectorJ::Zero();
};

}  // namespace hyq::servo
