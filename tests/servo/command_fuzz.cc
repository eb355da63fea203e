// libFuzzer target for every LCM handler input the daemon has (one malformed datagram must never
// kill it): the command channel's authenticator (servo/command/command_auth.h), the command
// decoder behind it and the field checks (servo/command/command_channel.h). Any bytes, as a
// datagram, are refused without a crash, an exception or UB; the same bytes wrapped with the
// robot's key reach the decoder and the validator, which also never crash; no random datagram
// passes as authentic.
//
// Built with clang++ -fsanitize=fuzzer,address,undefined by tests/servo/CMakeLists.txt when
// clang++ is found; the ctest servo.fuzz_command_30s runs it for 30 s (label fuzz).
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "servo/command/command_auth.h"
#include "servo/command/command_channel.h"

namespace {

using hyq::servo::AuthVerdict;

constexpr std::int64_t kNowUs = 1'800'000'000'000'000;

// the seeds' envelopes are signed with Key(1); the robot under test has Key(2), so they are
// well-formed envelopes with another robot's MAC
hyq::servo::CommandKey Key(int which) {
  hyq::servo::CommandKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i)
    k.bytes[i] = static_cast<std::uint8_t>(7 * i + static_cast<std::size_t>(which));
  return k;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const hyq::servo::CommandKey key = Key(2);
  static const hyq::servo::CommandValidator validator{hyq::servo::CommandChannelConfig{}};
  char why[128];
  hyq_lcm::lcmt_hyq_command msg;
  hyq::servo::ServoCommand out;

  // 1. the datagram as it arrives: never authentic (forging HMAC-SHA256 is not a fuzzer's job)
  hyq::servo::CommandAuthenticator auth(key, {});
  if (auth.Check(data, size, kNowUs, &msg, why, sizeof why) == AuthVerdict::kOk) std::abort();
  if (std::strlen(why) >= sizeof why) std::abort();

  // 2. the bare decoder and the rules on the same bytes
  if (hyq::servo::DecodeCommand(data, size, &msg, why, sizeof why))
    (void)validator.Validate(msg, &out, why, sizeof why);

  // 3. the bytes signed by the key holder: past the MAC, into the decoder, and (when they
  //    decode and are fresh) into the rules
  if (size >= 1 && size <= 4096) {
    const auto signed_bytes = hyq::servo::SignEncodedCommand(key, "fuzz", data, size);
    hyq::servo::CommandAuthenticator a(key, {});
    const AuthVerdict v =
        a.Check(signed_bytes.data(), signed_bytes.size(), kNowUs, &msg, why, sizeof why);
    if (v == AuthVerdict::kBadMac || v == AuthVerdict::kMalformed || v == AuthVerdict::kUnsigned)
      std::abort();  // an authentic envelope must get past the MAC
    if (v == AuthVerdict::kOk) (void)validator.Validate(msg, &out, why, sizeof why);
  }
  return 0;
}
