// The control stages of one cycle, in the order both the daemon (servo_loop.h) and the simulated
// experiment (tools/experiment/experiment.h) run them:
//   feet's force observer → friction estimate → disturbance observer → controller
// The friction estimator (friction_estimator.h) gives Stage I a μ per foot at or below the
// ceilings it is handed (the configured, commanded or true μ); the disturbance observer
// (disturbance_observer.h) estimates the trunk's wrench the model does not explain, and the
// controller uses h − [d_b; 0] where it uses the model's h (Controller::Compute). Both estimators
// read the nominal dynamics; the cycle's CycleDynamics is never changed.
// Never allocates, locks or throws after construction.
#pragma once

#include <array>

#include "dynamics/cycle_dynamics.h"
#include "dynamics/model.h"
#include "servo/common/servo_types.h"
#include "servo/control/controller.h"
#include "servo/estimation/disturbance_observer.h"
#include "servo/estimation/foot_force_observer.h"
#include "servo/estimation/friction_estimator.h"

namespace hyq::servo {

class ControlPipeline {
 public:
  /// Configuration time: builds every controller (QP workspaces) and both estimators, for a
  /// cycle of `period_s`. The friction estimator runs when `friction.enabled`, the observer when
  /// `disturbance.enabled`.
  ControlPipeline(const dynamics::Model& model, const ControllerConfig& controller,
                  const FrictionEstimatorConfig& friction,
                  const DisturbanceObserverConfig& disturbance, double period_s,
                  const FootForceObserverConfig& feet = {});

  /// One cycle at the measured state: `dyn` = ComputeCycleDynamics(model, q, v) (kOk),
  /// `tau_measured_Nm` the load cells' joint torques, `stance` the feet taken as loaded for the
  /// friction estimate, `slip_evidence` the feet whose slip velocity is measured against a base
  /// velocity the state estimator vouches for (StateEstimator::slip_evidence), `ref` the joint reference, `mu_ceiling` the μ per foot Stage I may get at
  /// most (with the estimator off, what it gets). Fills *out; returns the controller's status.
  IdStatus Compute(const dynamics::CycleDynamics& dyn, const VectorQ& q, const VectorV& v,
                   const VectorJ& tau_measured_Nm, const std::array<bool, kNumFeet>& stance,
                   const std::array<bool, kNumFeet>& slip_evidence, const JointReference& ref, const ContactEnvironment& mu_ceiling,
                   IdOutput* out) noexcept;

  /// The feet's force observer alone, for a cycle without control that still needs to know
  /// which feet carry load (the sit-down's damping).
  void ObserveFeet(const dynamics::CycleDynamics& dyn, const VectorV& v,
                   const VectorJ& tau_measured_Nm) noexcept {
    feet_.Update(dyn, v, tau_measured_Nm);
  }

  /// A cycle without control (not ACTIVE, or its inputs failed their checks): the μ the
  /// controller would get stays the ceiling, or the last estimate below it.
  void HoldEnvironment(const ContactEnvironment& mu_ceiling) noexcept;

  /// Clears the controller's state and the observer's filter (on each entry into ACTIVE).
  void Reset() noexcept;

  /// The μ (and normals) the controller got in the last Compute or HoldEnvironment.
  const ContactEnvironment& environment() const noexcept { return env_; }
  Controller& controller() noexcept { return controller_; }
  const Controller& controller() const noexcept { return controller_; }
  const FrictionEstimator& friction() const noexcept { return friction_; }
  const DisturbanceObserver& disturbance() const noexcept { return disturbance_; }
  /// The feet's ground forces and contact probabilities (foot_force_observer.h), run in every
  /// Compute: what the gait's contact-aware phases follow.
  const FootForceObserver& feet() const noexcept { return feet_; }

 private:
  void EstimateFriction(const dynamics::CycleDynamics& dyn, const VectorV& v,
                        const VectorJ& tau_measured_Nm, const std::array<bool, kNumFeet>& stance,
                        const std::array<bool, kNumFeet>& slip_evidence,
                        const ContactEnvironment& mu_ceiling) noexcept;

  const dynamics::Model& model_;
  double dt_;
  bool friction_enabled_, disturbance_enabled_;
  Controller controller_;
  FrictionEstimator friction_;
  DisturbanceObserver disturbance_;
  FootForceObserver feet_;
  ContactEnvironment env_;
};

}  // namespace hyq::servo
