#include "servo/runtime/output_checker.h"

#include <algorithm>
#include <cmath>

namespace hyq::servo {

Fault CheckEstimate(EstimatorStatus status, const Eigen::Matrix3d& R_WB,
                    const SafetyLimits& limits) noexcept {
  if (status != EstimatorStatus::kOk)
    return MakeFault(EventReason::kEstimatorFailure, -1, -1, "estimator: %s", ToString(status));
  const double tilt = std::acos(std::clamp(R_WB(2, 2), -1.0, 1.0));
  if (tilt > limits.max_tilt_rad)
    return MakeFault(EventReason::kEstimatorFailure, -1, -1, "base tilt %.3f rad beyond %.3f",
                     tilt, limits.max_tilt_rad);
  return {};
}

Fault CheckDynamics(dynamics::DynamicsStatus status) noexcept {
  if (status == dynamics::DynamicsStatus::kOk) return {};
  return MakeFault(EventReason::kControllerFailure, -1, -1, "dynamics: %s",
                   dynamics::ToString(status));
}

Fault CheckControllerOutput(ControllerKind kind, IdStatus status, const IdOutput& out) noexcept {
  if (status != IdStatus::kBadInput && out.fallback != Fallback::kSafety && out.tau_Nm.allFinite())
    return {};
  return MakeFault(EventReason::kControllerFailure, -1, -1, "controller %s: status %s, fallback %s",
                   ToString(kind), ToString(status), ToString(out.fallback));
}

}  // namespace hyq::servo
