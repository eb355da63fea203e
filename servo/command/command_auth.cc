#include "servo/command/command_auth.h"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "hyq_lcm/lcmt_hyq_signed_command.hpp"
#include "servo/command/command_channel.h"

namespace hyq::servo {
namespace {

constexpr char kMacContext[] = "hyq_signed_command/1";  // sizeof includes its NUL
constexpr std::size_t kMacSize = 32;
constexpr std::size_t kMaxCommand = 4096;

// HMAC-SHA256(key, context NUL sender NUL command): the sender is bound to the command, and the
// context keeps a MAC made for anything else from passing here.
bool Mac(const CommandKey& key, std::string_view sender, const std::uint8_t* command,
         std::size_t command_size, std::uint8_t* out) {
  std::vector<std::uint8_t> in;
  in.reserve(sizeof kMacContext + sender.size() + 1 + command_size);
  in.insert(in.end(), kMacContext, kMacContext + sizeof kMacContext);
  in.insert(in.end(), sender.begin(), sender.end());
  in.push_back(0);
  in.insert(in.end(), command, command + command_size);
  unsigned int n = 0;
  return HMAC(EVP_sha256(), key.bytes.data(), static_cast<int>(key.bytes.size()), in.data(),
              in.size(), out, &n) != nullptr &&
         n == kMacSize;
}

int HexDigit(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

const char* ToString(AuthVerdict v) noexcept {
  switch (v) {
    case AuthVerdict::kOk: return "ok";
    case AuthVerdict::kMalformed: return "malformed";
    case AuthVerdict::kUnsigned: return "unsigned";
    case AuthVerdict::kBadMac: return "bad_mac";
    case AuthVerdict::kUndecodable: return "undecodable";
    case AuthVerdict::kStale: return "stale";
    case AuthVerdict::kReplayed: return "replayed";
    case AuthVerdict::kTooManySenders: return "too_many_senders";
  }
  return "?";
}

CommandKey LoadCommandKey(const std::string& path) {
  const auto fail = [&](const std::string& what) {
    throw std::invalid_argument("command key file '" + path + "': " + what);
  };
  if (path.empty()) fail("expected a path (commands.key_file), found none");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) fail(std::string("cannot open it (") + std::strerror(errno) + ")");
  struct stat st {};
  char text[80];
  ssize_t n = -1;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) n = ::read(fd, text, sizeof text);
  ::close(fd);
  if (!S_ISREG(st.st_mode)) fail("expected a regular file, found another kind of file");
  if (st.st_uid != ::geteuid() && st.st_uid != 0)
    fail("expected it owned by uid " + std::to_string(::geteuid()) + " (this process) or root, found uid " +
         std::to_string(st.st_uid));
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    fail(std::string("expected mode 0600 or 0400 (no access for group or others), found ") + mode +
         " (chmod 600 it)");
  }
  std::size_t len = n < 0 ? 0 : static_cast<std::size_t>(n);
  if (len > 0 && text[len - 1] == '\n') --len;
  if (len != 64) fail("expected 64 hex digits, found " + std::to_string(len) + " bytes");
  CommandKey key;
  for (std::size_t i = 0; i < 32; ++i) {
    const int hi = HexDigit(text[2 * i]), lo = HexDigit(text[2 * i + 1]);
    if (hi < 0 || lo < 0) fail("expected 64 hex digits, found a non-hex character at " + std::to_string(2 * i + (hi < 0 ? 0 : 1)));
    key.bytes[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  OPENSSL_cleanse(text, sizeof text);
  return key;
}

void GenerateCommandKey(const std::string& path) {
  CommandKey key;
  if (::getrandom(key.bytes.data(), key.bytes.size(), 0) != static_cast<ssize_t>(key.bytes.size()))
    throw std::runtime_error("command key file '" + path + "': getrandom failed");
  char text[66];
  for (std::size_t i = 0; i < 32; ++i) std::snprintf(text + 2 * i, 3, "%02x", key.bytes[i]);
  text[64] = '\n';
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0)
    throw std::runtime_error("command key file '" + path + "': cannot create it (" +
                             std::strerror(errno) + "; an existing key is never overwritten)");
  const bool ok = ::write(fd, text, 65) == 65 && ::fsync(fd) == 0;
  ::close(fd);
  OPENSSL_cleanse(text, sizeof text);
  OPENSSL_cleanse(key.bytes.data(), key.bytes.size());
  if (!ok) {
    ::unlink(path.c_str());
    throw std::runtime_error("command key file '" + path + "': writing it failed");
  }
}

std::vector<std::uint8_t> SignEncodedCommand(const CommandKey& key, std::string_view sender,
                                             const std::uint8_t* command, std::size_t size) {
  if (sender.empty() || sender.size() > kMaxSenderBytes || sender.find('\0') != std::string_view::npos)
    throw std::invalid_argument("sender: expected 1.." + std::to_string(kMaxSenderBytes) +
                                " bytes without NUL, found " + std::to_string(sender.size()));
  if (size < 1 || size > kMaxCommand)
    throw std::invalid_argument("command: expected 1.." + std::to_string(kMaxCommand) +
                                " encoded bytes, found " + std::to_string(size));
  hyq_lcm::lcmt_hyq_signed_command s;
  s.sender = std::string(sender);
  s.command.assign(command, command + size);
  s.command_size = static_cast<std::int32_t>(size);
  if (!Mac(key, sender, command, size, s.mac)) throw std::runtime_error("HMAC-SHA256 failed");
  std::vector<std::uint8_t> out(static_cast<std::size_t>(s.getEncodedSize()));
  s.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

std::string DefaultCommandKeyFile() {
  const char* env_key = std::getenv("HYQ_COMMAND_KEY");
  return env_key != nullptr && *env_key != '\0' ? env_key : "/etc/hyq/command.key";
}

std::string DefaultCommandSender() {
  const char* user = std::getenv("USER");
  char host[64] = "host";
  (void)gethostname(host, sizeof host - 1);
  std::string sender = std::string(user != nullptr && *user != '\0' ? user : "operator") + "@" + host;
  if (sender.size() > kMaxSenderBytes) sender.resize(kMaxSenderBytes);
  return sender;
}

std::vector<std::uint8_t> SignCommand(const CommandKey& key, std::string_view sender,
                                      const hyq_lcm::lcmt_hyq_command& command) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(command.getEncodedSize()));
  if (command.encode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0)
    throw std::invalid_argument("command: cannot be encoded");
  return SignEncodedCommand(key, sender, bytes.data(), bytes.size());
}

CommandAuthenticator::CommandAuthenticator(const CommandKey& key, const CommandAuthConfig& config)
    : key_(key), config_(config) {
  senders_.reserve(config.max_senders);
}

AuthVerdict CommandAuthenticator::Check(const void* data, std::size_t size, std::int64_t now_us,
                                        hyq_lcm::lcmt_hyq_command* command, char* why,
                                        std::size_t n) noexcept {
  try {
    // layout (lcm-gen, big endian): hash 8, sender: int32 length (incl. NUL) + bytes,
    // command_size int32, command bytes, mac 32
    const auto* b = static_cast<const std::uint8_t*>(data);
    if (size >= 8 && ReadBigEndian(b, 8) == hyq_lcm::lcmt_hyq_command::getHash()) {
      std::snprintf(why, n, "auth: expected a signed command, found an unsigned lcmt_hyq_command");
      return AuthVerdict::kUnsigned;
    }
    constexpr std::size_t kMin = 8 + 4 + 2 + 4 + 1 + kMacSize;
    if (size < kMin || size > 8 + 4 + kMaxSenderBytes + 1 + 4 + kMaxCommand + kMacSize ||
        ReadBigEndian(b, 8) != hyq_lcm::lcmt_hyq_signed_command::getHash()) {
      std::snprintf(why, n, "auth: expected lcmt_hyq_signed_command (%zu..%zu bytes), found %zu bytes",
                    kMin, 8 + 4 + kMaxSenderBytes + 1 + 4 + kMaxCommand + kMacSize, size);
      return AuthVerdict::kMalformed;
    }
    const std::int64_t sender_len = ReadBigEndian(b + 8, 4);  // includes the NUL
    if (sender_len < 2 || sender_len > static_cast<std::int64_t>(kMaxSenderBytes + 1) ||
        static_cast<std::size_t>(12 + sender_len + 4 + kMacSize) > size) {
      std::snprintf(why, n, "sender: expected 1..%zu bytes, found a length of %lld", kMaxSenderBytes,
                    static_cast<long long>(sender_len - 1));
      return AuthVerdict::kMalformed;
    }
    const auto* sender_at = reinterpret_cast<const char*>(b + 12);
    const std::string_view sender(sender_at, static_cast<std::size_t>(sender_len - 1));
    if (sender_at[sender_len - 1] != '\0' || sender.find('\0') != std::string_view::npos) {
      std::snprintf(why, n, "sender: expected a NUL-terminated name, found other bytes");
      return AuthVerdict::kMalformed;
    }
    const std::size_t size_at = 12 + static_cast<std::size_t>(sender_len);
    const std::int64_t command_size = ReadBigEndian(b + size_at, 4);
    if (command_size < 1 ||
        static_cast<std::size_t>(command_size) != size - size_at - 4 - kMacSize) {
      std::snprintf(why, n, "command_size: expected %zu (bytes before the mac), found %lld",
                    size - size_at - 4 - kMacSize, static_cast<long long>(command_size));
      return AuthVerdict::kMalformed;
    }
    const std::uint8_t* inner = b + size_at + 4;
    const std::uint8_t* mac = inner + command_size;
    std::uint8_t expected[kMacSize];
    if (!Mac(key_, sender, inner, static_cast<std::size_t>(command_size), expected) ||
        CRYPTO_memcmp(expected, mac, kMacSize) != 0) {
      std::snprintf(why, n, "auth: expected this robot's MAC, found another (wrong key or altered; "
                            "'%.16s')", sender_at);
      return AuthVerdict::kBadMac;
    }
    // authenticated: only now is the command itself parsed
    if (!DecodeCommand(inner, static_cast<std::size_t>(command_size), command, why, n))
      return AuthVerdict::kUndecodable;
    // compared without subtracting: a sender's utime may be anything (the fuzzer found the
    // overflow of now - utime)
    const std::int64_t max_us = config_.max_age.count() * 1000;
    if (command->utime < now_us - max_us || command->utime > now_us + max_us) {
      const double age_us = static_cast<double>(now_us) - static_cast<double>(command->utime);
      std::snprintf(why, n, "utime: expected within %lld ms of the robot's clock, found %+.0f ms "
                            "('%.16s')",
                    static_cast<long long>(config_.max_age.count()), -age_us / 1e3,
                    sender_at);
      return AuthVerdict::kStale;
    }
    Sender* from = nullptr;
    for (Sender& s : senders_)
      if (s.name == sender) from = &s;
    if (from != nullptr && command->sequence <= from->last_sequence) {
      std::snprintf(why, n, "sequence: expected > %lld, found %lld (replayed or out of order; '%.16s')",
                    static_cast<long long>(from->last_sequence),
                    static_cast<long long>(command->sequence), sender_at);
      return AuthVerdict::kReplayed;
    }
    if (from == nullptr) {
      if (senders_.size() >= config_.max_senders) {
        std::snprintf(why, n, "sender: expected one of %zu known (table full), found '%.16s'",
                      senders_.size(), sender_at);
        return AuthVerdict::kTooManySenders;
      }
      senders_.push_back({std::string(sender), 0});
      from = &senders_.back();
    }
    from->last_sequence = command->sequence;
    return AuthVerdict::kOk;
  } catch (...) {  // an allocation for a sender's name
    std::snprintf(why, n, "auth: out of memory checking a command");
    return AuthVerdict::kMalformed;
  }
}

}  // namespace hyq::servo
