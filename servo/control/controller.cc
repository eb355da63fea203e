#include "servo/control/controller.h"

#include <algorithm>

namespace hyq::servo {
namespace {

constexpr double kMinRampedMu = 0.02;  // a landing foot's μ below this: frictionless (0)

TwoStageSettings Stage1Only(TwoStageSettings s) {
  s.stage2 = false;
  return s;
}
TwoStageSettings WithStage2(TwoStageSettings s) {
  s.stage2 = true;
  return s;
}
dynamics::VectorJ EffortLimits(const dynamics::Model& m) {
  dynamics::VectorJ e;
  for (int j = 0; j < dynamics::kNumJoints; ++j) e(j) = m.limits[j].effort_Nm;
  return e;
}

}  // namespace

Controller::Controller(const dynamics::Model& model, const ControllerConfig& config)
    : model_(model),
      config_(config),
      pid_(config.pid, EffortLimits(model)),
      pd_gravity_(config.pd_gravity, EffortLimits(model)),
      stage1_(Stage1Only(config.id)),
      two_stage_(WithStage2(config.id)),
      effort_limit_(EffortLimits(model)) {}

void Controller::SetKind(ControllerKind kind) noexcept {
  if (kind == config_.kind) return;
  config_.kind = kind;
  Reset();
}

void Controller::Reset() noexcept {
  pid_.Reset();
  stage1_.Reset();
  two_stage_.Reset();
  id_integral_.setZero();
}

IdStatus Controller::Compute(const dynamics::CycleDynamics& dyn, const dynamics::Vector6d& d_b,
                             const VectorQ& q, const VectorV& v, const JointReference& ref,
                             const ContactEnvironment& env, double dt, IdOutput* out) noexcept {
  h_corrected_ = dyn.bias;
  h_corrected_.head<dynamics::kNumBaseDofs>() -= d_b;
  return ComputeWithBias(dyn, h_corrected_, q, v, ref, env, dt, out);
}

IdStatus Controller::ComputeWithBias(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h,
                                     const VectorQ& q, const VectorV& v, const JointReference& ref,
                                     const ContactEnvironment& env, double dt,
                                     IdOutput* out) noexcept {
  const auto qj = q.tail<dynamics::kNumJoints>();
  const auto vj = v.tail<dynamics::kNumJoints>();
  // the feedback gains' scale per joint: swing legs' joints get this controller's swing scale
  const double swing = config_.kind == ControllerKind::kPid         ? config_.pid_swing_gain_scale
                       : config_.kind == ControllerKind::kPdGravity ? config_.pdg_swing_gain_scale
                                                                    : config_.swing_gain_scale;
  // a foot that has just landed takes the stance gains over its takeover ramp (the leg is still
  // light: the stance gains at once would ring it behind the actuator's lag)
  dynamics::VectorJ scale = dynamics::VectorJ::Ones();
  for (int f = 0; f < dynamics::kNumFeet; ++f) {
    const auto i = static_cast<std::size_t>(f);
    const double w = ref.stance[i] ? std::clamp(ref.takeover[i], 0.0, 1.0) : 0.0;
    scale.segment<dynamics::kJointsPerLeg>(dynamics::kJointsPerLeg * f)
        .setConstant(swing + (1.0 - swing) * w);
  }
  if (config_.kind == ControllerKind::kPid) {
    *out = IdOutput{};
    out->tau_Nm = pid_.Compute(qj, vj, ref.q, ref.qd, dt, &scale);
    return IdStatus::kOk;
  }
  if (config_.kind == ControllerKind::kPdGravity) {
    *out = IdOutput{};
    out->tau_Nm = pd_gravity_.Compute(dyn, h, qj, vj, ref.q, ref.qd, ref.stance, &scale);
    return IdStatus::kOk;
  }
  const FeedbackGains& g = config_.feedback;
  input_.q = q;
  input_.v = v;
  input_.qdd_des = ref.qdd + scale.cwiseProduct(g.kp_acc.cwiseProduct(ref.q - qj) +
                                                g.kd_acc.cwiseProduct(ref.qd - vj));
  input_.stance = ref.stance;
  // a newly landed foot's μ rises with its takeover: Stage I is still eqs 10–30 with a valid
  // Coulomb cone per foot, so the torque stays the exact inverse of a contact model (a bound on
  // the normal impulse instead would break eq 28: docs/servo.md, "Contact-aware gait"). Below
  // kMinRampedMu the foot is frictionless outright: a cone of μ ≈ 0 has nearly dependent rows,
  // which cost the QP its iteration limit
  for (std::size_t f = 0; f < kNumFeet; ++f) {
    if (!ref.stance[f]) {
      input_.mu[f] = env.mu[f];
      continue;
    }
    const double mu = env.mu[f] * std::clamp(ref.friction_takeover[f], 0.0, 1.0);
    input_.mu[f] = mu < std::min(kMinRampedMu, env.mu[f]) ? 0.0 : mu;
  }
  input_.normal_W = env.normal_W;
  input_.dt = config_.id.horizon_s > 0.0 ? config_.id.horizon_s : dt;
  IdStatus st = IdStatus::kBadInput;
  switch (config_.kind) {
    case ControllerKind::kNoSlipId: st = noslip_.Solve(model_, dyn, h, input_, out); break;
    case ControllerKind::kStage1Id: st = stage1_.Solve(model_, dyn, h, input_, out); break;
    case ControllerKind::kTwoStageId: st = two_stage_.Solve(model_, dyn, h, input_, out); break;
    case ControllerKind::kPid:
    case ControllerKind::kPdGravity: break;
  }
  if (st != IdStatus::kBadInput) {
    out->tau_Nm += scale.cwiseProduct(g.kp_tau.cwiseProduct(ref.q - qj) + g.kd_tau.cwiseProduct(ref.qd - vj));
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      const double e = ref.q(j) - qj(j), lim = effort_limit_(j);
      const double unsat = out->tau_Nm(j) + id_integral_(j);
      const bool saturated_along_e = (unsat > lim && e > 0.0) || (unsat < -lim && e < 0.0);
      if (!saturated_along_e)
        id_integral_(j) = std::clamp(id_integral_(j) + g.ki_tau(j) * e * dt, -g.i_limit_tau(j),
                                     g.i_limit_tau(j));
      out->tau_Nm(j) += id_integral_(j);
    }
  }
  return st;
}

}  // namespace hyq::servo
