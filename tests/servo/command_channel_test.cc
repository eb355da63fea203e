// The command channel's decoder on hostile datagrams (the generated decoder throws
// std::length_error on a negative count, which inside the LCM handler would kill the daemon):
// a negative foot count, a zero or oversized string length, truncations and random corruption are
// refused with a reason, and nothing escapes.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "servo/command/command_channel.h"

namespace hyq::servo {
namespace {

using K = hyq_lcm::lcmt_hyq_command;

std::vector<unsigned char> Encode(const K& m) {
  std::vector<unsigned char> b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

K SetMu(const char* controller) {
  K m{};
  m.sequence = 7;
  m.kind = K::KIND_SET_MU;
  m.num_feet = 4;
  m.mu = {0.1, 0.2, 0.3, 0.4};
  m.controller = controller;
  m.kp_scale = m.kd_scale = 1.0;
  return m;
}

K Enable() {
  K m{};
  m.sequence = 7;
  m.kind = K::KIND_ENABLE;
  m.num_feet = 0;
  m.controller = "";
  m.kp_scale = m.kd_scale = 1.0;
  return m;
}

TEST(DecodeCommand, AcceptsWhatTheGeneratedEncoderWrites) {
  const K mu = SetMu("two_stage");
  const auto b = Encode(mu);
  K out;
  char why[kEventDetailSize];
  ASSERT_TRUE(DecodeCommand(b.data(), b.size(), &out, why, sizeof why)) << why;
  EXPECT_EQ(out.sequence, 7);
  EXPECT_EQ(out.mu, mu.mu);
  EXPECT_EQ(out.controller, "two_stage");
}

TEST(DecodeCommand, SetVelocityCarriesItsThreeAxes) {
  K m = Enable();
  m.kind = K::KIND_SET_VELOCITY;
  m.velocity[0] = 0.25;
  m.velocity[1] = -0.1;
  m.velocity[2] = 0.4;
  const auto b = Encode(m);
  K out;
  char why[kEventDetailSize];
  ASSERT_TRUE(DecodeCommand(b.data(), b.size(), &out, why, sizeof why)) << why;
  EXPECT_EQ(out.velocity[0], 0.25);
  EXPECT_EQ(out.velocity[1], -0.1);
  EXPECT_EQ(out.velocity[2], 0.4);
  // the velocity is the fixed tail: one byte short is refused with a reason
  EXPECT_FALSE(DecodeCommand(b.data(), b.size() - 1, &out, why, sizeof why));
  const CommandValidator v{CommandChannelConfig{}};
  ServoCommand c;
  ASSERT_TRUE(v.Validate(out, &c, why, sizeof why)) << why;
  EXPECT_EQ(c.kind, ServoCommand::Kind::kSetVelocity);
  out.velocity[0] = 0.5;  // beyond the default 0.4 m/s
  EXPECT_FALSE(v.Validate(out, &c, why, sizeof why));
  EXPECT_STREQ(why, "velocity.vx: expected [-0.4, 0.4] m/s, found 0.5");
}

TEST(DecodeCommand, NegativeFootCountIsRefusedNotThrown) {
  auto b = Encode(Enable());  // 71 bytes: an empty string is its length and a NUL
  ASSERT_EQ(b.size(), 71u);
  b[25] = 0xff;  // num_feet = -1
  K out;
  char why[kEventDetailSize];
  EXPECT_FALSE(DecodeCommand(b.data(), b.size(), &out, why, sizeof why));
  EXPECT_NE(std::strstr(why, "num_feet: expected 0.."), nullptr) << why;
  EXPECT_NE(std::strstr(why, "found -1"), nullptr) << why;
  // and the generated decoder alone would have thrown (what killed the daemon)
  EXPECT_THROW(out.decode(b.data(), 0, static_cast<int>(b.size())), std::length_error);
}

TEST(DecodeCommand, ZeroAndOversizedStringLengthsAreRefused) {
  auto b = Encode(Enable());
  const std::size_t len_at = 26;  // num_feet = 0: the string length follows at once
  for (const std::uint32_t len : {0u, 0x7fffffffu, 0xffffffffu, 2u}) {
    for (int i = 0; i < 4; ++i) b[len_at + i] = static_cast<unsigned char>(len >> (24 - 8 * i));
    K out;
    char why[kEventDetailSize];
    EXPECT_FALSE(DecodeCommand(b.data(), b.size(), &out, why, sizeof why)) << len;
    EXPECT_NE(std::strstr(why, "controller: expected a string length"), nullptr) << why;
  }
}

TEST(DecodeCommand, TruncatedAndCorruptedDatagramsNeverThrow) {
  const auto good = Encode(SetMu("pid"));
  K out;
  char why[kEventDetailSize];
  for (std::size_t n = 0; n < good.size(); ++n)
    EXPECT_FALSE(DecodeCommand(good.data(), n, &out, why, sizeof why)) << n;
  std::mt19937 rng(12);
  int accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    auto b = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) b[rng() % b.size()] = static_cast<unsigned char>(rng());
    accepted += DecodeCommand(b.data(), b.size(), &out, why, sizeof why) ? 1 : 0;  // noexcept
  }
  EXPECT_LT(accepted, 20000);  // most corruptions hit the hash or a length
}

}  // namespace
}  // namespace hyq::servo
