#include "servo/runtime/command_port.h"

#include "servo/runtime/fault.h"

namespace hyq::servo {

ServoMode CommandPort::mode() const noexcept { return p_.safety->mode(); }
bool CommandPort::Enable(EventReason why) noexcept { return p_.safety->Enable(why); }
bool CommandPort::Disable() noexcept { return p_.safety->Disable(); }
bool CommandPort::Damp() noexcept { return p_.safety->Damp(); }
bool CommandPort::RequestAcknowledge() noexcept { return p_.safety->RequestAcknowledge(); }

void CommandPort::Note(EventReason reason, const char* detail) noexcept {
  p_.safety->Note(reason, detail);
}

void CommandPort::ReportFault(EventReason reason, const char* detail) noexcept {
  p_.safety->Report(MakeFault(reason, -1, -1, "%s", detail));
}

const char* CommandPort::EstimateNotReady() const noexcept {
  return *p_.estimate == EstimatorStatus::kOk ? nullptr : ToString(*p_.estimate);
}

void CommandPort::SetMu(const std::array<double, kNumFeet>& mu) noexcept {
  for (std::size_t f = 0; f < kNumFeet; ++f) p_.env->mu[f] = mu[f];
}

void CommandPort::SetControllerKind(ControllerKind kind) noexcept { p_.controller->SetKind(kind); }

void CommandPort::ScaleGains(double kp_scale, double kd_scale) noexcept {
  FeedbackGains g = *p_.base_gains;
  g.kp_acc *= kp_scale;
  g.kp_tau *= kp_scale;
  g.kd_acc *= kd_scale;
  g.kd_tau *= kd_scale;
  p_.controller->SetFeedback(g);
  PidGains pid = *p_.base_pid;
  pid.kp *= kp_scale;
  pid.kd *= kd_scale;
  p_.controller->SetPidGains(pid);
  PdGains pd = p_.controller->config().pd_gravity;  // the configured ones (never changed)
  pd.kp *= kp_scale;
  pd.kd *= kd_scale;
  p_.controller->SetPdGravityGains(pd);
}

bool CommandPort::SetVelocity(const std::array<double, 3>& v,
                              std::array<double, 3>* applied) noexcept {
  if (p_.reference == nullptr || !p_.reference->SetVelocity(v[0], v[1], v[2])) return false;
  *applied = p_.reference->commanded_velocity();
  return true;
}

}  // namespace hyq::servo
