// Authenticated, fresh operator commands (docs/security.md): a per-robot secret key in a file only
// its owner can read, an HMAC-SHA256 over the sender's name and the encoded command, a strictly
// increasing sequence per sender and a time window. Used on the telemetry thread (Check) and by
// hyq-command and the tests (Sign); nothing here runs in the servo cycle.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "hyq_lcm/lcmt_hyq_command.hpp"

namespace hyq::servo {

/// The robot's command key: 32 secret bytes.
struct CommandKey {
  std::array<std::uint8_t, 32> bytes{};
};

/// Reads a key file: 64 hex digits (optionally followed by a newline). The file must be a regular
/// file owned by the calling user (or root) with no permission for group or others (0600 or
/// 0400): a key anyone can read authenticates anyone.
/// @throws std::invalid_argument naming the file and what was expected and found.
CommandKey LoadCommandKey(const std::string& path);

/// Writes a new random key (getrandom) to `path`, created with mode 0600; refuses to overwrite.
/// @throws std::runtime_error naming the file.
void GenerateCommandKey(const std::string& path);

/// The longest sender name a signed command carries, in bytes.
inline constexpr std::size_t kMaxSenderBytes = 63;

/// The operator tools' defaults (hyq-command, hyq-teleop): the key file is $HYQ_COMMAND_KEY when
/// set, else /etc/hyq/command.key; the sender is USER@HOST, cut to 63 bytes.
std::string DefaultCommandKeyFile();
std::string DefaultCommandSender();

/// An lcmt_hyq_signed_command carrying `command` from `sender`, encoded and ready to publish.
/// @throws std::invalid_argument for a sender name outside 1..63 bytes.
std::vector<std::uint8_t> SignCommand(const CommandKey& key, std::string_view sender,
                                      const hyq_lcm::lcmt_hyq_command& command);
/// The same around bytes that are already encoded (or, in tests, not a command at all).
std::vector<std::uint8_t> SignEncodedCommand(const CommandKey& key, std::string_view sender,
                                             const std::uint8_t* command, std::size_t size);

/// What Check found, in the order it checks.
enum class AuthVerdict : std::uint8_t {
  kOk,
  kMalformed,        // not an lcmt_hyq_signed_command (lengths, hash)
  kUnsigned,         // a bare lcmt_hyq_command: no signature at all
  kBadMac,           // signed with another key, or altered on the way
  kUndecodable,      // the MAC holds but the command inside does not decode
  kStale,            // command.utime outside the time window of the robot's clock
  kReplayed,         // command.sequence not above the last accepted from this sender
  kTooManySenders,   // a new sender while the table of senders is full
};
const char* ToString(AuthVerdict v) noexcept;

struct CommandAuthConfig {
  std::chrono::milliseconds max_age{1000};  // |robot clock - command.utime| at most this
  std::size_t max_senders = 16;             // distinct senders remembered (their last sequence)
};

/// Checks signed commands. Not thread-safe: one instance per receiving thread.
class CommandAuthenticator {
 public:
  CommandAuthenticator(const CommandKey& key, const CommandAuthConfig& config);

  /// Checks one datagram received at `now_us` (µs since the Unix epoch, the robot's
  /// CLOCK_REALTIME). On kOk, *command is the decoded command and its sender's sequence is
  /// recorded; otherwise `why` says what was expected and what was found. Never throws.
  AuthVerdict Check(const void* data, std::size_t size, std::int64_t now_us,
                    hyq_lcm::lcmt_hyq_command* command, char* why, std::size_t why_size) noexcept;

  std::size_t num_senders() const noexcept { return senders_.size(); }

 private:
  struct Sender {
    std::string name;
    std::int64_t last_sequence = 0;
  };
  CommandKey key_;
  CommandAuthConfig config_;
  std::vector<Sender> senders_;
};

}  // namespace hyq::servo
