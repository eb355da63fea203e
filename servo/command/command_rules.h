// The mode rules of operator commands (docs/telemetry.md, "Commands"; the fields were validated
// on the telemetry thread, servo/command/command_channel.h): which command is taken in which
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

#include <array>
#include <cstdint>

#include "servo/common/servo_types.h"

namespace hyq::servo {

/// What a command acts on: the safety state machine's transitions and the setters of the
/// controller, the contact environment and the reference. servo/runtime implements it over the
/// loop's parts (servo/runtime/command_port.h), so that these rules need only servo/common and
/// the arrow points from runtime to command. Every call is noexcept and allocates nothing.
class CommandTarget {
 public:
  virtual ~CommandTarget() = default;

  // the safety state machine: the transitions of the same names (each refusal recorded there)
  virtual ServoMode mode() const noexcept = 0;
  virtual bool Enable(EventReason why) noexcept = 0;
  virtual bool Disable() noexcept = 0;
  virtual bool Damp() noexcept = 0;
  virtual bool RequestAcknowledge() noexcept = 0;
  virtual void Note(EventReason reason, const char* detail) noexcept = 0;
  /// A fault, as the cycle's checks report them (ACTIVE damps).
  virtual void ReportFault(EventReason reason, const char* detail) noexcept = 0;

  /// nullptr when the state estimate is ready, else what the estimator reports.
  virtual const char* EstimateNotReady() const noexcept = 0;

  // what the commands change
  virtual void SetMu(const std::array<double, kNumFeet>& mu) noexcept = 0;
  virtual void SetControllerKind(ControllerKind kind) noexcept = 0;
  /// Every controller's feedback gains: the configured ones, kp times kp_scale, kd times kd_scale.
  virtual void ScaleGains(double kp_scale, double kd_scale) noexcept = 0;
  /// Steers the trot; false when the reference is not the trot. *applied is the velocity taken
  /// (after the reference's own limits).
  virtual bool SetVelocity(const std::array<double, 3>& velocity,
                           std::array<double, 3>* applied) noexcept = 0;
};

enum class CommandOutcome : std::uint8_t {
  kApplied,         // taken (or refused by the state machine, which recorded the refusal)
  kRejected,        // refused by a rule here (counted as rejected)
  kEnabled,         // ACTIVE now: the caller starts the reference
  kAcknowledging,   // the caller asks the devices back to OP
};

/// Applies one validated command (or the kRejected marker of an invalid one) to `target`.
/// `damp_on_bad_command` is safety.damp_on_bad_command.
CommandOutcome ApplyCommand(const ServoCommand& c, bool damp_on_bad_command,
                            CommandTarget* target) noexcept;

}  // namespace hyq::servo
