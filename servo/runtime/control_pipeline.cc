#include "servo/runtime/control_pipeline.h"

#include <algorithm>

namespace hyq::servo {
ControlPipeline::ControlPipeline(const dynamics::Model& model, const ControllerConfig& controller,
                                 const FrictionEstimatorConfig& friction,
                                 const DisturbanceObserverConfig& disturbance, double period_s,
                                 const FootForceObserverConfig& feet)
    : model_(model),
      dt_(period_s),
      friction_enabled_(friction.enabled),
      disturbance_enabled_(disturbance.enabled),
      controller_(model, controller),
      friction_(friction),
      disturbance_(model, disturbance, period_s),
      feet_(model, feet, period_s) {}

void ControlPipeline::Reset() noexcept {
  controller_.Reset();
  disturbance_.Reset();
  feet_.Reset();
}

void ControlPipeline::HoldEnvironment(const ContactEnvironment& mu_ceiling) noexcept {
  env_.normal_W = mu_ceiling.normal_W;
  for (std::size_t f = 0; f < kNumFeet; ++f)
    env_.mu[f] = friction_enabled_ ? std::min(friction_.feet()[f].mu_control, mu_ceiling.mu[f])
                                   : mu_ceiling.mu[f];
}

IdStatus ControlPipeline::Compute(const dynamics::CycleDynamics& dyn, const VectorQ& q,
                                  const VectorV& v, const VectorJ& tau_measured_Nm,
                                  const std::array<bool, kNumFeet>& stance,
                                  const std::array<bool, kNumFeet>& slip_evidence,
                                  const JointReference& ref, const ContactEnvironment& mu_ceiling,
                                  IdOutput* out) noexcept {
  env_ = mu_ceiling;
  feet_.Update(dyn, v, tau_measured_Nm);
  if (friction_enabled_) EstimateFriction(dyn, v, tau_measured_Nm, stance, slip_evidence, mu_ceiling);
  // the observer's trunk wrench corrects the model's h for the controller only (h − d_b), after
  // the friction estimate took its forces from the nominal h
  if (!disturbance_enabled_) return controller_.Compute(dyn, q, v, ref, env_, dt_, out);
  const dynamics::Vector6d& d_b = disturbance_.Update(dyn, v, tau_measured_Nm);
  return controller_.Compute(dyn, d_b, q, v, ref, env_, dt_, out);
}

// the μ Stage I gets: the ceiling, or the estimate below it
void ControlPipeline::EstimateFriction(const dynamics::CycleDynamics& dyn, const VectorV& v,
                                       const VectorJ& tau_measured_Nm,
                                       const std::array<bool, kNumFeet>& stance,
                                       const std::array<bool, kNumFeet>& slip_evidence,
                                       const ContactEnvironment& mu_ceiling) noexcept {
  std::array<FootFrictionInput, kNumFeet> in;
  for (int f = 0; f < kNumFeet; ++f) {
    const auto i = static_cast<std::size_t>(f);
    const Eigen::Vector3d tau_leg = tau_measured_Nm.segment<dynamics::kJointsPerLeg>(3 * f);
    in[i] = MeasureFoot(model_, dyn, v, f, stance[i], tau_leg);
  }
  friction_.Update(in, slip_evidence, mu_ceiling.mu, dt_);
  for (std::size_t f = 0; f < kNumFeet; ++f) env_.mu[f] = friction_.feet()[f].mu_control;
}

}  // namespace hyq::servo
