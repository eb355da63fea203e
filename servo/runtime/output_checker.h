// Plausibility of what the cycle computed before it reaches the joints (docs/servo.md,
// "Safety"): the state estimate (ready, base tilt within max_tilt_rad) and the controller's
// output (no failed dynamics, no "safety" fallback, finite torques). Each returns a fault or
// none; the safety state machine decides what follows. Never allocates.
#pragma once

#include <Eigen/Core>

#include "dynamics/cycle_dynamics.h"
#include "servo/control/controller.h"
#include "servo/estimation/estimator.h"
#include "servo/runtime/fault.h"
#include "servo/runtime/safety_limits.h"

namespace hyq::servo {

/// The estimate may be used by a controller: status ok and the base tilt (from R_WB) within
/// limits.max_tilt_rad.
Fault CheckEstimate(EstimatorStatus status, const Eigen::Matrix3d& R_WB,
                    const SafetyLimits& limits) noexcept;

/// The dynamics of this cycle could be computed.
Fault CheckDynamics(dynamics::DynamicsStatus status) noexcept;

/// The controller's answer may be applied: not bad input, not the "safety" fallback, finite.
Fault CheckControllerOutput(ControllerKind kind, IdStatus status, const IdOutput& out) noexcept;

}  // namespace hyq::servo
