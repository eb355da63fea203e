// PID on joint positions: the paper's feedback-only baseline.
//   τ = Kp e + I + Kd ė,   e = q_ref − q,  ė = q̇_ref − q̇,  I ← clamp(I + Ki e dt, ±i_limit)
// Anti-windup: the integral is clamped to ±i_limit and does not grow while the output saturates
// in the direction of e (conditional integration). The output is clamped to the joint's effort
// limit.
#pragma once

#include "dynamics/model.h"

namespace hyq::servo {

struct PidGains {
  dynamics::VectorJ kp = dynamics::VectorJ::Zero();       // N·m/rad
  dynamics::VectorJ ki = dynamics::VectorJ::Zero();       // N·m/(rad·s)
  dynamics::VectorJ kd = dynamics::VectorJ::Zero();       // N·m·s/rad
  dynamics::VectorJ i_limit = dynamics::VectorJ::Zero();  // N·m, bound on the integral term
};

class PidController {
 public:
  PidController(const PidGains& gains, const dynamics::VectorJ& effort_limit_Nm);
  /// One step; never allocates. `gain_scale` (optional): per joint, multiplies kp and kd (not
  /// the integral), e.g. lower gains on swing legs (ControllerConfig::swing_gain_scale).
  dynamics::VectorJ Compute(const dynamics::VectorJ& q, const dynamics::VectorJ& qd,
                            const dynamics::VectorJ& q_ref, const dynamics::VectorJ& qd_ref,
                            double dt, const dynamics::VectorJ* gain_scale = nullptr) noexcept;
  void Reset() noexcept { integral_.setZero(); }
  const dynamics::VectorJ& integral() const noexcept { return integral_; }
  void set_gains(const PidGains& g) noexcept { gains_ = g; }
  const PidGains& gains() const noexcept { return gains_; }

 private:
  PidGains gains_;
  dynamics::VectorJ effort_limit_;
  dynamics::VectorJ integral_ = dynamics::VectorJ::Zero();
};

}  // namespace hyq::servo
