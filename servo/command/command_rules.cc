#include "servo/command/command_rules.h"

#include <cstdio>

namespace hyq::servo {

CommandOutcome ApplyCommand(const ServoCommand& c, bool damp_on_bad_command,
                            CommandTarget* target) noexcept {
  CommandTarget& t = *target;
  char d[kEventDetailSize];
  switch (c.kind) {
    case ServoCommand::Kind::kEnable:
      if (const char* status = t.EstimateNotReady(); status != nullptr) {
        std::snprintf(d, sizeof d, "enable refused: the state estimate is not ready (%s)", status);
        t.Note(EventReason::kCommandRejected, d);
        return CommandOutcome::kRejected;
      }
      return t.Enable(EventReason::kEnableCommand) ? CommandOutcome::kEnabled
                                                   : CommandOutcome::kApplied;
    case ServoCommand::Kind::kDisable:
      (void)t.Disable();
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kDamp:
      if (!t.Damp()) {
        std::snprintf(d, sizeof d, "damp refused in %s", ToString(t.mode()));
        t.Note(EventReason::kCommandRejected, d);
      }
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kAcknowledge:
      return t.RequestAcknowledge() ? CommandOutcome::kAcknowledging : CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetMu:
      t.SetMu(c.mu);
      std::snprintf(d, sizeof d, "mu = %.3f %.3f %.3f %.3f", c.mu[0], c.mu[1], c.mu[2], c.mu[3]);
      t.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetController:
      if (t.mode() == ServoMode::kActive ||
          static_cast<int>(c.controller) >= kNumControllerKinds) {
        std::snprintf(d, sizeof d, "controller change refused in %s (only outside active)",
                      ToString(t.mode()));
        t.Note(EventReason::kCommandRejected, d);
        return CommandOutcome::kRejected;
      }
      t.SetControllerKind(c.controller);
      std::snprintf(d, sizeof d, "controller = %s", ToString(c.controller));
      t.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetGains:
      t.ScaleGains(c.kp_scale, c.kd_scale);
      std::snprintf(d, sizeof d, "gains scaled kp x%.3f kd x%.3f", c.kp_scale, c.kd_scale);
      t.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    case ServoCommand::Kind::kSetVelocity: {
      std::array<double, 3> got{};
      if (!t.SetVelocity(c.velocity, &got)) {
        t.Note(EventReason::kCommandRejected,
               "velocity refused: reference: expected trot, found another reference");
        return CommandOutcome::kRejected;
      }
      std::snprintf(d, sizeof d, "velocity = %.3f m/s %.3f m/s %.3f rad/s", got[0], got[1], got[2]);
      t.Note(EventReason::kCommandApplied, d);
      return CommandOutcome::kApplied;
    }
    case ServoCommand::Kind::kRejected:
      if (damp_on_bad_command && t.mode() == ServoMode::kActive) {
        std::snprintf(d, sizeof d, "a refused command (sequence %llu) while active",
                      static_cast<unsigned long long>(c.sequence));
        t.ReportFault(EventReason::kCommandRejected, d);
      }
      return CommandOutcome::kRejected;
  }
  return CommandOutcome::kRejected;
}

}  // namespace hyq::servo
