#include "servo/control/pid_controller.h"

#include <algorithm>

namespace hyq::servo {

PidController::PidController(const PidGains& gains, const dynamics::VectorJ& effort_limit_Nm)
    : gains_(gains), effort_limit_(effort_limit_Nm) {}

dynamics::VectorJ PidController::Compute(const dynamics::VectorJ& q, const dynamics::VectorJ& qd,
                                         const dynamics::VectorJ& q_ref,
                                         const dynamics::VectorJ& qd_ref, double dt,
                                         const dynamics::VectorJ* gain_scale) noexcept {
  dynamics::VectorJ tau;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const double e = q_ref(j) - q(j);
    const double s = gain_scale != nullptr ? (*gain_scale)(j) : 1.0;
    const double pd = s * (gains_.kp(j) * e + gains_.kd(j) * (qd_ref(j) - qd(j)));
    const double lim = effort_limit_(j);
    const double unsat = pd + integral_(j);
    const bool saturated_along_e = (unsat > lim && e > 0.0) || (unsat < -lim && e < 0.0);
    if (!saturated_along_e)
      integral_(j) = std::clamp(integral_(j) + gains_.ki(j) * e * dt, -gains_.i_limit(j),
                                gains_.i_limit(j));
    tau(j) = std::clamp(pd + integral_(j), -lim, lim);
  }
  return tau;
}

}  // namespace hyq::servo
