// Authenticated commands (without them any local process could enable the robot, and a captured
// enable replayed later would be applied): the key file's checks, the MAC against an
// independent reference (Python's hmac module), and every refusal: unsigned, wrong key, altered,
// stale, replayed, out of order, malformed envelopes. Also the LCM URL checks.
#include "servo/command/command_auth.h"

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "servo/telemetry/lcm_url.h"

namespace hyq::servo {
namespace {

using K = hyq_lcm::lcmt_hyq_command;
namespace fs = std::filesystem;

constexpr std::int64_t kNowUs = 1'800'000'000'000'000;  // some time in 2027

CommandKey TestKey(std::uint8_t first = 0) {
  CommandKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(first + i);
  return k;
}

K Enable(std::int64_t sequence, std::int64_t utime = kNowUs) {
  K m{};
  m.utime = utime;
  m.sequence = sequence;
  m.kind = K::KIND_ENABLE;
  m.controller = "two_stage";
  m.kp_scale = m.kd_scale = 1.0;
  return m;
}

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/hyq_key_XXXXXX";
    path_ = ::mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string File(const std::string& name, const std::string& text, mode_t mode) const {
    const std::string p = path_ + "/" + name;
    std::ofstream(p) << text;
    ::chmod(p.c_str(), mode);
    return p;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

std::string ThrownBy(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

TEST(CommandAuth, MacMatchesPythonHmac) {
  // python3 -c "import hmac,hashlib; print(hmac.new(bytes(range(32)),
  //   b'hyq_signed_command/1\x00op@test\x00abc', hashlib.sha256).hexdigest())"
  const char* expected = "ba7a21bbcfba712707a57eaeda5426adede88dd80299090fadbd116b15c64c11";
  const std::uint8_t abc[] = {'a', 'b', 'c'};
  const std::vector<std::uint8_t> s = SignEncodedCommand(TestKey(), "op@test", abc, 3);
  ASSERT_GE(s.size(), 32u);
  char hex[65];
  for (std::size_t i = 0; i < 32; ++i) std::snprintf(hex + 2 * i, 3, "%02x", s[s.size() - 32 + i]);
  EXPECT_STREQ(hex, expected);
}

TEST(CommandAuth, AcceptsSignedAndFreshOnceEach) {
  CommandAuthenticator auth(TestKey(), {});
  char why[128];
  K got;
  const auto a = SignCommand(TestKey(), "op@console", Enable(10));
  EXPECT_EQ(auth.Check(a.data(), a.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk) << why;
  EXPECT_EQ(got.kind, int{K::KIND_ENABLE});
  EXPECT_EQ(got.sequence, 10);
  EXPECT_EQ(got.controller, "two_stage");

  // the same datagram again, 1.3 s later as in the finding (still inside a wide window): replayed
  EXPECT_EQ(auth.Check(a.data(), a.size(), kNowUs + 300'000, &got, why, sizeof why),
            AuthVerdict::kReplayed);
  EXPECT_NE(std::string(why).find("sequence: expected > 10, found 10"), std::string::npos) << why;
  // an older one that was held back: out of order
  const auto older = SignCommand(TestKey(), "op@console", Enable(9));
  EXPECT_EQ(auth.Check(older.data(), older.size(), kNowUs, &got, why, sizeof why),
            AuthVerdict::kReplayed);
  // the next one is taken; another sender has its own sequence
  const auto next = SignCommand(TestKey(), "op@console", Enable(11));
  EXPECT_EQ(auth.Check(next.data(), next.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk);
  const auto other = SignCommand(TestKey(), "ci@bench", Enable(1));
  EXPECT_EQ(auth.Check(other.data(), other.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk);
  EXPECT_EQ(auth.num_senders(), 2u);
}

TEST(CommandAuth, StaleOrFromTheFutureIsRefused) {
  CommandAuthConfig c;
  c.max_age = std::chrono::milliseconds(1000);
  CommandAuthenticator auth(TestKey(), c);
  char why[128];
  K got;
  const auto old = SignCommand(TestKey(), "op", Enable(1, kNowUs - 1'300'000));
  EXPECT_EQ(auth.Check(old.data(), old.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kStale);
  EXPECT_NE(std::string(why).find("utime: expected within 1000 ms of the robot's clock, found -1300 ms"),
            std::string::npos) << why;
  const auto future = SignCommand(TestKey(), "op", Enable(2, kNowUs + 1'300'000));
  EXPECT_EQ(auth.Check(future.data(), future.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kStale);
  // any utime at all, without overflow in the check (the command fuzzer found now - INT64_MIN)
  for (const std::int64_t t : {std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max()}) {
    const auto far = SignCommand(TestKey(), "op", Enable(3, t));
    EXPECT_EQ(auth.Check(far.data(), far.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kStale);
  }
  // a refused stale command does not advance the sequence: a fresh one with a lower number passes
  const auto fresh = SignCommand(TestKey(), "op", Enable(1, kNowUs - 999'000));
  EXPECT_EQ(auth.Check(fresh.data(), fresh.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk) << why;
}

TEST(CommandAuth, UnsignedWrongKeyAndAlteredAreRefused) {
  CommandAuthenticator auth(TestKey(), {});
  char why[128];
  K got;
  // a bare lcmt_hyq_command, as any local process could send before
  const K bare = Enable(1);
  std::vector<std::uint8_t> b(static_cast<std::size_t>(bare.getEncodedSize()));
  bare.encode(b.data(), 0, static_cast<int>(b.size()));
  EXPECT_EQ(auth.Check(b.data(), b.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kUnsigned);
  EXPECT_NE(std::string(why).find("expected a signed command"), std::string::npos) << why;
  // signed with another key
  const auto wrong = SignCommand(TestKey(100), "op", Enable(2));
  EXPECT_EQ(auth.Check(wrong.data(), wrong.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kBadMac);
  EXPECT_NE(std::string(why).find("expected this robot's MAC"), std::string::npos) << why;
  // every single byte of a good one flipped: never accepted
  const auto good = SignCommand(TestKey(), "op", Enable(3));
  for (std::size_t i = 0; i < good.size(); ++i) {
    std::vector<std::uint8_t> bad = good;
    bad[i] ^= 0x20;
    CommandAuthenticator fresh(TestKey(), {});
    EXPECT_NE(fresh.Check(bad.data(), bad.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk)
        << "byte " << i;
  }
  // a command signed as coming from one sender does not pass as another's: the sender is in the MAC
  std::vector<std::uint8_t> swapped = SignCommand(TestKey(), "op", Enable(4));
  swapped[12] = 'x';  // first byte of the sender name
  EXPECT_EQ(auth.Check(swapped.data(), swapped.size(), kNowUs, &got, why, sizeof why),
            AuthVerdict::kBadMac);
}

TEST(CommandAuth, MalformedEnvelopesAndUndecodableCommandsNeverThrow) {
  CommandAuthenticator auth(TestKey(), {});
  char why[128];
  K got;
  const auto good = SignCommand(TestKey(), "op", Enable(1));
  for (std::size_t n = 0; n < good.size(); ++n)  // every truncation
    EXPECT_NE(auth.Check(good.data(), n, kNowUs, &got, why, sizeof why), AuthVerdict::kOk) << n;
  std::vector<std::uint8_t> neg = good;
  neg[8] = neg[9] = neg[10] = neg[11] = 0xff;  // sender length -1
  EXPECT_EQ(auth.Check(neg.data(), neg.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kMalformed);
  // the key holder wraps bytes that are no command (num_feet = -1): authentic, but undecodable
  K m = Enable(2);
  std::vector<std::uint8_t> inner(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(inner.data(), 0, static_cast<int>(inner.size()));
  inner[25] = 0xff;
  const auto wrapped = SignEncodedCommand(TestKey(), "op", inner.data(), inner.size());
  EXPECT_EQ(auth.Check(wrapped.data(), wrapped.size(), kNowUs, &got, why, sizeof why),
            AuthVerdict::kUndecodable);
  EXPECT_NE(std::string(why).find("num_feet"), std::string::npos) << why;
  // random bytes
  std::mt19937 rng(3);
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> r(rng() % 200);
    for (auto& x : r) x = static_cast<std::uint8_t>(rng());
    if (i % 2 == 0 && r.size() >= 8) std::copy(good.begin(), good.begin() + 8, r.begin());  // right hash
    EXPECT_NE(auth.Check(r.data(), r.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk);
  }
}

TEST(CommandAuth, SenderTableIsBounded) {
  CommandAuthConfig c;
  c.max_senders = 2;
  CommandAuthenticator auth(TestKey(), c);
  char why[128];
  K got;
  for (const char* s : {"a", "b"}) {
    const auto m = SignCommand(TestKey(), s, Enable(1));
    EXPECT_EQ(auth.Check(m.data(), m.size(), kNowUs, &got, why, sizeof why), AuthVerdict::kOk);
  }
  const auto third = SignCommand(TestKey(), "c", Enable(1));
  EXPECT_EQ(auth.Check(third.data(), third.size(), kNowUs, &got, why, sizeof why),
            AuthVerdict::kTooManySenders);
  EXPECT_THROW(SignCommand(TestKey(), "", Enable(1)), std::invalid_argument);
  EXPECT_THROW(SignCommand(TestKey(), std::string(64, 'x'), Enable(1)), std::invalid_argument);
}

TEST(CommandKeyFile, OwnerModeAndFormatAreChecked) {
  TempDir d;
  const std::string hex(64, 'a');
  const std::string good = d.File("good.key", hex + "\n", 0600);
  EXPECT_EQ(LoadCommandKey(good).bytes[0], 0xaa);
  EXPECT_EQ(LoadCommandKey(d.File("ro.key", hex, 0400)).bytes[31], 0xaa);

  std::string e = ThrownBy([&] { LoadCommandKey(d.File("open.key", hex, 0644)); });
  EXPECT_NE(e.find("open.key': expected mode 0600 or 0400"), std::string::npos) << e;
  EXPECT_NE(e.find("found 0644"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(d.File("group.key", hex, 0640)); });
  EXPECT_NE(e.find("found 0640"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(d.path() + "/missing.key"); });
  EXPECT_NE(e.find("missing.key': cannot open it"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(d.path()); });
  EXPECT_NE(e.find("expected a regular file"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(d.File("short.key", "abcd\n", 0600)); });
  EXPECT_NE(e.find("expected 64 hex digits, found 4 bytes"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(d.File("nothex.key", std::string(63, 'a') + "g", 0600)); });
  EXPECT_NE(e.find("non-hex character at 63"), std::string::npos) << e;
  e = ThrownBy([&] { LoadCommandKey(""); });
  EXPECT_NE(e.find("expected a path"), std::string::npos) << e;
  if (::geteuid() == 0) {  // root may use a key owned by someone else only if it is root's
    const std::string other = d.File("other.key", hex, 0600);
    ASSERT_EQ(::chown(other.c_str(), 1234, 1234), 0);
    e = ThrownBy([&] { LoadCommandKey(other); });
    EXPECT_NE(e.find("found uid 1234"), std::string::npos) << e;
  } else {
    std::printf("(the foreign-owner case needs root to chown; not run)\n");
  }
}

TEST(CommandKeyFile, GeneratedKeysAreRandomPrivateAndNeverOverwritten) {
  TempDir d;
  const std::string p = d.path() + "/new.key", q = d.path() + "/other.key";
  GenerateCommandKey(p);
  GenerateCommandKey(q);
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const CommandKey a = LoadCommandKey(p), b = LoadCommandKey(q);
  EXPECT_NE(a.bytes, b.bytes);
  const std::string e = ThrownBy([&] { GenerateCommandKey(p); });
  EXPECT_NE(e.find("never overwritten"), std::string::npos) << e;
  EXPECT_EQ(LoadCommandKey(p).bytes, a.bytes);
}

TEST(LcmUrlCheck, BadUrlsNameThePart) {
  EXPECT_EQ(ParseLcmUrl("udpm://239.255.76.67:7667?ttl=0", "u").port, 7667);
  EXPECT_EQ(ParseLcmUrl("udpm://239.255.76.67:7668?ttl=1&recv_buf_size=2097152", "u").ttl, 1);
  EXPECT_EQ(ParseLcmUrl("memq://", "u").provider, "memq");
  EXPECT_EQ(ParseLcmUrl("file:///tmp/x.lcmlog?mode=w", "u").target, "/tmp/x.lcmlog");
  const struct {
    const char* url;
    const char* message;
  } bad[] = {
      {"udp::99999", "u: expected an LCM URL"},
      {"udpm://[[[::", "u (group): expected a dotted IPv4 multicast address, found '[[[:'"},
      {"udpm://10.0.0.1:7667", "u (group): expected a multicast address in 224.0.0.0/4"},
      {"udpm://239.255.76.67:99999", "u (port): expected 1..65535, found '99999'"},
      {"udpm://239.255.76.67:0", "u (port): expected 1..65535, found '0'"},
      {"udpm://239.255.76.67:7667?ttl=300", "u (ttl): expected 0..255, found '300'"},
      {"udpm://239.255.76.67:7667?tll=0", "u (option): expected ttl or recv_buf_size, found 'tll=0'"},
      {"tcpq://localhost", "u: expected the provider udpm, memq or file"},
  };
  for (const auto& b : bad) {
    const std::string e = ThrownBy([&] { ParseLcmUrl(b.url, "u"); });
    EXPECT_NE(e.find(b.message), std::string::npos) << b.url << ": " << e;
  }
}

TEST(LcmUrlCheck, GroupRoutesViaLoopbackInTheTestNamespace) {
  if (std::getenv("HYQ_NETNS") == nullptr)
    GTEST_SKIP() << "needs in_netns.sh (a namespace whose multicast route is 224.0.0.0/4 dev lo)";
  EXPECT_EQ(InterfaceForGroup("239.255.76.67", 7667), "lo");
}

}  // namespace
}  // namespace hyq::servo
