#include "servo/runtime/command_rules.h"

#include <cstdio>

namespace hyq::servo {

CommandOutcome ApplyCommand(const ServoCommand& c, EstimatorStatus estimate,
                            const CommandTargets& t) noexcept {
  SafetyStateMachine& safety = *t.safety;
  char d[kEventDetailSize];
  switch (c.kind) {
    case ServoCommand::Kind::kEnable:
      if (estimate != EstimatorStatus::kOk) {
        std::snprintf(d, sizeof d, "enable refused: the state estimate is not ready (%s)",
                      ToString(estimate));
        safety.Note(EventReason::kCommandRejected, d);
        return CommandOutcome::kRejected;
      }
      return safety.Enable(EventReason::kEnableCommand) ? CommandOutcome::kEnabled
                                                        : CommandOutcome::kApplied;
    case ServoCommand::Kind::kDisable:
      (void)safety.Disable();
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kDamp:
      if (!safety.Damp()) {
        std::snprintf(d, sizeof d, "damp refused in %s", ToString(safety.mode()));
        safety.Note(EventReason::kCommandRejected, d);
      }
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kAcknowledge:
      return safety.RequestAcknowledge() ? CommandOutcome::kAcknowledging
                                         : CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetMu:
      for (std::size_t f = 0; f < kNumFeet; ++f) t.env->mu[f] = c.mu[f];
      std::snprintf(d, sizeof d, "mu = %.3f %.3f %.3f %.3f", c.mu[0], c.mu[1], c.mu[2], c.mu[3]);
      safety.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetController:
      if (safety.mode() == ServoMode::kActive ||
          static_cast<int>(c.controller) >= kNumControllerKinds) {
        std::snprintf(d, sizeof d, "controller change refused in %s (only outside active)",
                      ToString(safety.mode()));
        safety.Note(EventReason::kCommandRejected, d);
        return CommandOutcome::kRejected;
      }
      t.controller->SetKind(c.controller);
      std::snprintf(d, sizeof d, "controller = %s", ToString(c.controller));
      safety.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetGains: {
      FeedbackGains g = *t.base_gains;
      g.kp_acc *= c.kp_scale;
      g.kp_tau *= c.kp_scale;
      g.kd_acc *= c.kd_scale;
      g.kd_tau *= c.kd_scale;
      t.controller->SetFeedback(g);
      PidGains p = *t.base_pid;
      p.kp *= c.kp_scale;
      p.kd *= c.kd_scale;
      t.controller->SetPidGains(p);
      PdGains pg = t.controller->config().pd_gravity;  // the configured ones (never changed)
      pg.kp *= c.kp_scale;
      pg.kd *= c.kd_scale;
      t.controller->SetPdGravityGains(pg);
      std::snprintf(d, sizeof d, "gains scaled kp x%.3f kd x%.3f", c.kp_scale, c.kd_scale);
      safety.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    }
    case ServoCommand::Kind::kSetVelocity: {
      const auto& v = c.velocity;
      if (t.reference == nullptr || !t.reference->SetVelocity(v[0], v[1], v[2])) {
        safety.Note(EventReason::kCommandRejected,
                    "velocity refused: reference: expected trot, found another reference");
        return CommandOutcome::kRejected;
      }
      const auto& got = t.reference->commanded_velocity();
      std::snprintf(d, sizeof d, "velocity = %.3f m/s %.3f m/s %.3f rad/s", got[0], got[1], got[2]);
      safety.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    }
    case ServoCommand::Kind::kRejected:
      if (t.damp_on_bad_command && safety.mode() == ServoMode::kActive)
        safety.Report(MakeFault(EventReason::kCommandRejected, -1, -1,
                                "a refused command (sequence %llu) while active",
                                static_cast<unsigned long long>(c.sequence)));
      return CommandOutcome::kRejected;
  }
  return CommandOutcome::kRejected;
}

}  // namespace hyq::servo
