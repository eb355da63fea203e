// The operator command channel's rules (docs/telemetry.md, "Commands"), apart from any LCM
// instance: decode an lcmt_hyq_command, validate its fields against CommandChannelConfig, and
// rate-limit what is accepted. Used on the telemetry thread; Validate is pure, so tests check
// every rule without a network.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "servo/common/servo_types.h"
#include "servo/command/command_config.h"

namespace hyq::servo {

/// The signed integer of `bytes` (1..8) bytes at `p` in LCM's wire order (big endian): the
/// length fields the decoder and the authenticator check before trusting them.
std::int64_t ReadBigEndian(const std::uint8_t* p, int bytes) noexcept;

/// Decodes one datagram as lcmt_hyq_command without trusting its length fields: a negative
/// foot count, a string length of 0 or beyond the datagram, a wrong hash or a short buffer is
/// refused (false, `why` says what was expected and found); nothing thrown escapes (the generated
/// decoder throws std::length_error on a negative count).
bool DecodeCommand(const void* data, std::size_t size, hyq_lcm::lcmt_hyq_command* msg, char* why,
                   std::size_t why_size) noexcept;

/// A channel name liblcm will not read as a regular expression when subscribing: 1..63 of
/// [A-Za-z0-9_] (a pattern like "HYQ_.*" would make the daemon hear its own telemetry).
bool IsPlainChannelName(const std::string& name) noexcept;

class CommandValidator {
 public:
  using Clock = std::chrono::steady_clock;

  /// @throws std::invalid_argument naming the field for an unusable configuration: unknown
  ///         controller names; when enabled, also a non-positive rate, empty ranges, no channel.
  explicit CommandValidator(const CommandChannelConfig& config);
  /// The range checks alone (what the constructor does for an enabled channel).
  static void CheckRanges(const CommandChannelConfig& config);

  /// Checks a decoded message; fills `out` when valid, else writes why (expected, found) into
  /// `why`. Never allocates on the accept path.
  bool Validate(const hyq_lcm::lcmt_hyq_command& msg, ServoCommand* out, char* why,
                std::size_t why_size) const;

  /// Rate limit: whether a valid command at `now` may be accepted (at least 1 / max_rate_hz after
  /// the last accepted one); when not, `why` says so. Accepted() records an acceptance.
  bool RateAllows(Clock::time_point now, char* why, std::size_t why_size) const;
  void Accepted(Clock::time_point now) noexcept;

  const CommandChannelConfig& config() const noexcept { return config_; }

 private:
  CommandChannelConfig config_;
  std::vector<ControllerKind> allowed_;
  Clock::time_point last_accepted_{};
  bool accepted_any_ = false;
};

}  // namespace hyq::servo
