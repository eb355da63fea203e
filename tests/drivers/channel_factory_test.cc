// The channel spec grammar: what parses to what, and the message a bad spec throws; the
// throwing set-up wrappers.
#include "drivers/channel_factory.h"

#include <gtest/gtest.h>

#include "drivers/candump.h"
#include "drivers/channel_error.h"
#include "drivers/channel_setup.h"

namespace hyq::drivers {
namespace {

TEST(ChannelSpec, SocketCan) {
  auto s = std::get<SocketCanOptions>(ParseChannelSpec("socketcan:vcan0"));
  EXPECT_EQ(s.interface, "vcan0");
  EXPECT_EQ(s.fd, FdMode::kAuto);
  s = std::get<SocketCanOptions>(ParseChannelSpec("socketcan-fd:can1,rcvbuf=262144,batch=16"));
  EXPECT_EQ(s.interface, "can1");
  EXPECT_EQ(s.fd, FdMode::kRequire);
  EXPECT_EQ(s.receive_buffer_bytes, 262144);
  EXPECT_EQ(s.batch, 16u);
  EXPECT_EQ(std::get<SocketCanOptions>(ParseChannelSpec("socketcan-classic:can2")).fd,
            FdMode::kOff);
}

TEST(ChannelSpec, Udp) {
  auto u = std::get<UdpMulticastOptions>(ParseChannelSpec("udp:239.74.163.2:43113"));
  EXPECT_EQ(u.group, "239.74.163.2");
  EXPECT_EQ(u.port, 43113);
  EXPECT_EQ(u.ttl, 0);
  EXPECT_TRUE(u.fd);
  u = std::get<UdpMulticastOptions>(ParseChannelSpec("udp"));
  EXPECT_EQ(u.group, kDefaultUdpGroup);
  EXPECT_EQ(u.port, kDefaultUdpPort);
  u = std::get<UdpMulticastOptions>(ParseChannelSpec("udp::5000,ttl=1,fd=0,iface=127.0.0.1"));
  EXPECT_EQ(u.group, kDefaultUdpGroup);
  EXPECT_EQ(u.port, 5000);
  EXPECT_EQ(u.ttl, 1);
  EXPECT_FALSE(u.fd);
  EXPECT_EQ(u.interface_address, "127.0.0.1");
  u = std::get<UdpMulticastOptions>(ParseChannelSpec("udp:239.1.2.3,ttl=2"));
  EXPECT_EQ(u.group, "239.1.2.3");
  EXPECT_EQ(u.port, kDefaultUdpPort);
}

TEST(ChannelSpec, Replay) {
  auto r = std::get<ReplayOptions>(ParseChannelSpec("replay:logs/a.log,iface=can0,timing=realtime"));
  EXPECT_EQ(r.path, "logs/a.log");
  EXPECT_EQ(r.iface, "can0");
  EXPECT_EQ(r.timing, ReplayTiming::kRealTime);
}

TEST(ChannelSpec, BadSpecsSayWhatWasExpectedAndFound) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "expected socketcan:IF"},
      {"can:vcan0", "found 'can'"},
      {"socketcan", "socketcan:IFNAME"},
      {"socketcan:", "interface name of 1..15"},
      {"socketcan:abcdefghijklmnop", "found 'abcdefghijklmnop'"},
      {"socketcan:vcan0,speed=1", "found 'speed'"},
      {"socketcan:vcan0,batch", "KEY=VALUE"},
      {"udp:239.74.163.2:70000", "port (an integer 1..65535), found '70000'"},
      {"udp:239.74.163.2:x", "found 'x'"},
      {"udp,ttl=256", "ttl (an integer 0..255)"},
      {"udp,fd=maybe", "fd (0 or 1)"},
      {"replay:", "log file path"},
      {"replay:a.log,timing=slow", "found 'slow'"},
  };
  for (const auto& [spec, part] : bad) {
    try {
      (void)ParseChannelSpec(spec);
      ADD_FAILURE() << "accepted '" << spec << "'";
    } catch (const ChannelError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("channel spec '" + spec + "'"), std::string::npos) << msg;
      EXPECT_NE(msg.find(part), std::string::npos) << msg;
    }
  }
}

TEST(ChannelSpec, OpenFailuresNameTheSpec) {
  try {
    (void)OpenChannel("replay:/nonexistent/x.log");
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_NE(std::string(e.what()).find("channel spec 'replay:/nonexistent/x.log'"),
              std::string::npos)
        << e.what();
  }
  // no AF_CAN here (or no such interface where there is): either way a message naming it
  try {
    (void)OpenChannel("socketcan:nosuchcan9");
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_NE(std::string(e.what()).find("socketcan:nosuchcan9"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hyq::drivers

namespace hyq::drivers {
namespace {

TEST(ChannelSetup, ThrowingWrappersNameChannelAndStatus) {
  CandumpRecord r;
  r.frame.id = 0x123;
  r.frame.len = 1;
  ReplayChannel ch({r, r}, "", ReplayTiming::kAsFast, false, "replay:test");
  std::array<hal::CanFrame, 4> out;
  EXPECT_EQ(ReceiveOrThrow(ch, out), 2u);
  hal::CanFrame good = r.frame, fd = r.frame;
  fd.flags = hal::CanFrame::kFd;
  const std::array<hal::CanFrame, 3> frames = {good, good, fd};
  SendAllOrThrow(ch, std::span<const hal::CanFrame>(frames.data(), 2));
  try {
    SendAllOrThrow(ch, frames);
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_STREQ(e.what(), "replay:test: send of frame 3 of 3 failed: bad_frame");
  }
}

}  // namespace
}  // namespace hyq::drivers
