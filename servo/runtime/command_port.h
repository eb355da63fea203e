// The loop's side of the command rules (servo/command/command_rules.h): what a command may change,
// the safety state machine, the controller, the contact environment and the reference, behind
// the CommandTarget interface the rules take. Built once with the loop; servo thread only.
#pragma once

#include <array>

#include "servo/command/command_rules.h"
#include "servo/control/controller.h"
#include "servo/estimation/estimator.h"
#include "servo/reference/reference.h"
#include "servo/runtime/safety_state_machine.h"

namespace hyq::servo {

/// The pointers a command acts through. None may be null except `reference` (then velocity
/// commands are refused); all outlive the port.
struct CommandPortParts {
  SafetyStateMachine* safety = nullptr;
  Controller* controller = nullptr;
  ContactEnvironment* env = nullptr;
  const FeedbackGains* base_gains = nullptr;  // the configured gains (scaled by kSetGains)
  const PidGains* base_pid = nullptr;
  Reference* reference = nullptr;             // steered by kSetVelocity
  const EstimatorStatus* estimate = nullptr;  // the loop's latest estimator status
};

class CommandPort final : public CommandTarget {
 public:
  explicit CommandPort(const CommandPortParts& parts) : p_(parts) {}

  ServoMode mode() const noexcept override;
  bool Enable(EventReason why) noexcept override;
  bool Disable() noexcept override;
  bool Damp() noexcept override;
  bool RequestAcknowledge() noexcept override;
  void Note(EventReason reason, const char* detail) noexcept override;
  void ReportFault(EventReason reason, const char* detail) noexcept override;
  const char* EstimateNotReady() const noexcept override;
  void SetMu(const std::array<double, kNumFeet>& mu) noexcept override;
  void SetControllerKind(ControllerKind kind) noexcept override;
  void ScaleGains(double kp_scale, double kd_scale) noexcept override;
  bool SetVelocity(const std::array<double, 3>& velocity,
                   std::array<double, 3>* applied) noexcept override;

 private:
  CommandPortParts p_;
};

}  // namespace hyq::servo
