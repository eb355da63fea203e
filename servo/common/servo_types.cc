#include "servo/common/servo_types.h"

namespace hyq::servo {

const char* ToString(ServoMode m) noexcept {
  switch (m) {
    case ServoMode::kInit: return "init";
    case ServoMode::kStandby: return "standby";
    case ServoMode::kActive: return "active";
    case ServoMode::kDamping: return "damping";
    case ServoMode::kFault: return "fault";
    case ServoMode::kStopped: return "stopped";
  }
  return "?";
}

const char* ToString(StopClass c) noexcept {
  switch (c) {
    case StopClass::kNone: return "none";
    case StopClass::kControlled: return "controlled";
    case StopClass::kDegraded: return "degraded";
    case StopClass::kCut: return "cut";
  }
  return "?";
}

const char* ToString(EventReason r) noexcept {
  switch (r) {
    case EventReason::kNone: return "none";
    case EventReason::kBringUpComplete: return "bring_up_complete";
    case EventReason::kEnableCommand: return "enable_command";
    case EventReason::kDisableCommand: return "disable_command";
    case EventReason::kDampingCommand: return "damping_command";
    case EventReason::kAcknowledge: return "acknowledge";
    case EventReason::kStopRequest: return "stop_request";
    case EventReason::kDampingDone: return "damping_done";
    case EventReason::kDeviceFault: return "device_fault";
    case EventReason::kInputMissing: return "input_missing";
    case EventReason::kBusOff: return "bus_off";
    case EventReason::kCorruptFrames: return "corrupt_frames";
    case EventReason::kNonFiniteInput: return "non_finite_input";
    case EventReason::kOutOfRange: return "out_of_range";
    case EventReason::kInputJump: return "input_jump";
    case EventReason::kControllerFailure: return "controller_failure";
    case EventReason::kDeadlineMiss: return "deadline_miss";
    case EventReason::kEstimatorFailure: return "estimator_failure";
    case EventReason::kCommandRejected: return "command_rejected";
    case EventReason::kCommandApplied: return "command_applied";
    case EventReason::kForeignMaster: return "foreign_master";
    case EventReason::kCount: break;
  }
  return "?";
}

const char* ToString(ControllerKind k) noexcept {
  switch (k) {
    case ControllerKind::kPid: return "pid";
    case ControllerKind::kNoSlipId: return "noslip";
    case ControllerKind::kStage1Id: return "stage1";
    case ControllerKind::kTwoStageId: return "two_stage";
    case ControllerKind::kPdGravity: return "pd_gravity";
  }
  return "unknown";
}

std::optional<ControllerKind> ParseControllerKind(std::string_view name) noexcept {
  for (int k = 0; k < kNumControllerKinds; ++k)
    if (name == ToString(static_cast<ControllerKind>(k))) return static_cast<ControllerKind>(k);
  return std::nullopt;
}

std::vector<hal::Choice<ControllerKind>> ControllerKindChoices() {
  std::vector<hal::Choice<ControllerKind>> c;
  for (int k = 0; k < kNumControllerKinds; ++k)
    c.push_back({ToString(static_cast<ControllerKind>(k)), static_cast<ControllerKind>(k)});
  return c;
}

const char* ToString(ServoCommand::Kind k) noexcept {
  switch (k) {
    case ServoCommand::Kind::kEnable: return "enable";
    case ServoCommand::Kind::kDisable: return "disable";
    case ServoCommand::Kind::kDamp: return "damp";
    case ServoCommand::Kind::kAcknowledge: return "ack";
    case ServoCommand::Kind::kSetMu: return "mu";
    case ServoCommand::Kind::kSetController: return "controller";
    case ServoCommand::Kind::kSetGains: return "gains";
    case ServoCommand::Kind::kSetVelocity: return "velocity";
    case ServoCommand::Kind::kRejected: return "rejected";
  }
  return "unknown";
}

}  // namespace hyq::servo
