// The mode rules of operator commands (docs/telemetry.md, "Commands"; the fields were validated
// on the telemetry thread, servo/telemetry/command_channel.h): which command is taken in which
// mode and what it changes. Servo thread; never allocates.
//
//   enable      STANDBY → ACTIVE, only with a ready state estimate
//   disable     ACTIVE → STANDBY
//   damp        ACTIVE / STANDBY → DAMPING
//   ack         in FAULT: the devices are asked back to OP, STANDBY once they are (handshake)
//   mu          the friction per foot the controller uses, any mode
//   controller  the controller kind, outside ACTIVE only
//   gains       the feedback gains, scaled copies of the configured ones, any mode
//   velocity    the trot's commanded base velocity, any mode (the reference holds still outside
//               ACTIVE); refused when the reference is not the trot
//   rejected    an invalid command: DAMPING if ACTIVE and safety.damp_on_bad_command
#pragma once

#include <cstdint>

#include "servo/common/servo_types.h"
#include "servo/control/controller.h"
#include "servo/estimation/estimator.h"
#include "servo/reference/reference.h"
#include "servo/runtime/safety_state_machine.h"

namespace hyq::servo {

/// What a command may change.
struct CommandTargets {
  SafetyStateMachine* safety = nullptr;
  Controller* controller = nullptr;
  ContactEnvironment* env = nullptr;
  const FeedbackGains* base_gains = nullptr;  // the configured gains (scaled by kSetGains)
  const PidGains* base_pid = nullptr;
  Reference* reference = nullptr;             // steered by kSetVelocity
  bool damp_on_bad_command = true;
};

enum class CommandOutcome : std::uint8_t {
  kApplied,         // taken (or refused by the state machine, which recorded the refusal)
  kRejected,        // refused by a rule here (counted as rejected)
  kEnabled,         // ACTIVE now: the caller starts the reference
  kAcknowledging,   // the caller asks the devices back to OP
};

CommandOutcome ApplyCommand(const ServoCommand& c, EstimatorStatus estimate,
                            const CommandTargets& t) noexcept;

}  // namespace hyq::servo
