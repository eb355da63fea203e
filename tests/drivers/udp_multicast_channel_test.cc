// The virtual CAN channel over UDP multicast, two or more channels in one private network
// namespace (tests/drivers/in_netns.sh).
#include "drivers/udp_multicast_channel.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>
#include <vector>

#include "drivers/candump.h"
#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "drivers/socket_util.h"
#include "tests/drivers/test_util.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::drivers::testing {
namespace {

using hal::CanFrame;
using hal::CanStatus;

UdpMulticastOptions Opts(std::uint16_t port, bool fd = true) {
  UdpMulticastOptions o;
  o.port = port;
  o.fd = fd;
  return o;
}

std::vector<CanFrame> AllKinds() {
  return {Classic(0x181, {1, 2, 3, 4, 5, 6, 7, 8}), Classic(0x0, {}),
          Classic(0x1ABCDEF0, {0xFF}, true),        Remote(0x701, 1),
          Error(0x40, {0, 0, 0, 0, 0, 0, 0, 0}),    Fd(0x281, 64, 1, true, false),
          Fd(0x1F000281, 20, 2, false, true, true), Fd(0x381, 0, 0)};
}

TEST(UdpMulticastChannel, TwoChannelsExchangeFramesAndDropOwnEchoes) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel a(Opts(TestPort())), b(Opts(TestPort()));
  EXPECT_NE(a.sender_port(), b.sender_port());
  EXPECT_EQ(a.name(), "udp:239.74.163.2:" + std::to_string(TestPort()));
  const std::vector<CanFrame> frames = AllKinds();
  const std::int64_t before = internal::RealtimeNs();
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  ASSERT_EQ(sent, frames.size());
  const std::vector<CanFrame> got = ReceiveN(b, frames.size());
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(SameFrame(got[i], frames[i]));
    EXPECT_GE(got[i].timestamp_ns, before);  // kernel receive time, CLOCK_REALTIME
    EXPECT_LE(got[i].timestamp_ns, internal::RealtimeNs());
  }
  EXPECT_EQ(Drain(a, std::chrono::milliseconds(50)), 0u) << "own echoes must be dropped";
  // and the other direction
  ASSERT_EQ(b.Send(std::span<const CanFrame>(frames.data(), 2), &sent), CanStatus::kOk);
  EXPECT_EQ(ReceiveN(a, 2).size(), 2u);
  EXPECT_EQ(Drain(b, std::chrono::milliseconds(20)), 0u);

  EXPECT_EQ(a.counters().tx_frames, frames.size());
  EXPECT_EQ(b.counters().rx_frames, frames.size());
  EXPECT_EQ(b.counters().error_frames, 1u);
  EXPECT_EQ(a.counters().rx_frames, 2u);
  EXPECT_EQ(a.counters().bad_frames + b.counters().bad_frames, 0u);
  EXPECT_EQ(b.counters().rx_overflow, 0u);
}

TEST(UdpMulticastChannel, ThreeMembersAllHearEachOther) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel a(Opts(TestPort())), b(Opts(TestPort())), c(Opts(TestPort()));
  const CanFrame f = Classic(0x80, {});
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  EXPECT_EQ(ReceiveN(b, 1).size(), 1u);
  EXPECT_EQ(ReceiveN(c, 1).size(), 1u);
  EXPECT_EQ(Drain(a, std::chrono::milliseconds(20)), 0u);
}

TEST(UdpMulticastChannel, DifferentGroupsOrPortsAreSeparateBuses) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel a(Opts(TestPort(0))), other_port(Opts(TestPort(1)));
  UdpMulticastOptions og = Opts(TestPort(0));
  og.group = "239.74.163.3";
  UdpMulticastChannel other_group(og), same(Opts(TestPort(0)));
  const CanFrame f = Classic(0x123, {1});
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  EXPECT_EQ(ReceiveN(same, 1).size(), 1u);
  EXPECT_EQ(Drain(other_port, std::chrono::milliseconds(30)), 0u);
  EXPECT_EQ(Drain(other_group, std::chrono::milliseconds(0)), 0u);
}

TEST(UdpMulticastChannel, BatchSendAndDrainKeepOrder) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastOptions small_batch = Opts(TestPort());
  small_batch.batch = 7;  // many sendmmsg/recvmmsg calls per Send/Receive
  small_batch.receive_buffer_bytes = 1 << 20;
  UdpMulticastChannel a(small_batch), b(small_batch);
  std::vector<CanFrame> frames;
  for (std::uint32_t i = 0; i < 300; ++i)
    frames.push_back(i % 3 == 0 ? Fd(i, 16, static_cast<std::uint8_t>(i))
                                : Classic(i, {static_cast<std::uint8_t>(i)}));
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  ASSERT_EQ(sent, frames.size());
  const std::vector<CanFrame> got = ReceiveN(b, frames.size(), std::chrono::seconds(5), 50);
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i]));
  // an empty span is a no-op
  std::size_t k = 1;
  EXPECT_EQ(b.Receive({}, &k), CanStatus::kOk);
  EXPECT_EQ(k, 0u);
  EXPECT_EQ(a.Send({}, &k), CanStatus::kOk);
  EXPECT_EQ(k, 0u);
}

TEST(UdpMulticastChannel, ClassicChannelRefusesAndDropsFdFrames) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel fd(Opts(TestPort())), classic(Opts(TestPort(), false));
  EXPECT_FALSE(classic.fd_enabled());
  const std::vector<CanFrame> frames = {Classic(1, {1}), Fd(2, 12, 0), Classic(3, {3})};
  std::size_t sent = 0;
  EXPECT_EQ(classic.Send(frames, &sent), CanStatus::kBadFrame);
  EXPECT_EQ(sent, 1u);  // stops before the frame it cannot carry
  EXPECT_EQ(classic.counters().bad_frames, 1u);
  EXPECT_EQ(ReceiveN(fd, 1).size(), 1u);

  ASSERT_EQ(fd.Send(frames, &sent), CanStatus::kOk);
  const std::vector<CanFrame> got = ReceiveN(classic, 2);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, 1u);
  EXPECT_EQ(got[1].id, 3u);
  EXPECT_EQ(classic.counters().bad_frames, 2u);  // its own refused send + the FD frame it heard
}

TEST(UdpMulticastChannel, InvalidFramesAreRefused) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel a(Opts(TestPort()));
  CanFrame bad = Classic(0x800, {});
  std::size_t sent = 9;
  EXPECT_EQ(a.Send(std::span<const CanFrame>(&bad, 1), &sent), CanStatus::kBadFrame);
  EXPECT_EQ(sent, 0u);
  bad = Fd(1, 9, 0);
  EXPECT_EQ(a.Send(std::span<const CanFrame>(&bad, 1), &sent), CanStatus::kBadFrame);
  EXPECT_EQ(a.counters().bad_frames, 2u);
}

TEST(UdpMulticastChannel, MalformedDatagramsAreCountedNotPassedUp) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel b(Opts(TestPort()));
  const int s = socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(s, 0);
  const int ttl = 0;
  setsockopt(s, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(TestPort());
  inet_pton(AF_INET, "239.74.163.2", &to.sin_addr);
  const std::vector<std::vector<std::uint8_t>> junk = {
      {}, {0x00}, {0x8B}, {0xC1}, {0x81, 0xA1, 'x', 0x01}, std::vector<std::uint8_t>(5000, 0x90)};
  for (const auto& d : junk)
    ASSERT_EQ(sendto(s, d.data(), d.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(d.size()));
  close(s);
  EXPECT_EQ(Drain(b, std::chrono::milliseconds(50)), 0u);
  EXPECT_EQ(b.counters().bad_frames, junk.size());
  EXPECT_EQ(b.counters().rx_frames, 0u);
}

TEST(UdpMulticastChannel, ReceiveOverflowIsCounted) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastOptions tiny = Opts(TestPort());
  tiny.receive_buffer_bytes = 4096;  // the kernel doubles it; a few datagrams fit
  UdpMulticastChannel a(Opts(TestPort())), b(tiny);
  std::vector<CanFrame> frames(200, Classic(0x100, {1, 2, 3, 4, 5, 6, 7, 8}));
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  std::size_t got = Drain(b, std::chrono::milliseconds(50));
  // drops are reported with the next datagram queued after them: send a marker and read up to it
  const CanFrame marker = Classic(0x101, {});
  ASSERT_EQ(a.Send(std::span<const CanFrame>(&marker, 1), &sent), CanStatus::kOk);
  bool saw_marker = false;
  std::array<CanFrame, 64> buf;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!saw_marker && std::chrono::steady_clock::now() < deadline) {
    std::size_t k = 0;
    ASSERT_EQ(b.Receive(buf, &k), CanStatus::kOk);
    got += k;
    for (std::size_t i = 0; i < k; ++i) saw_marker |= buf[i].id == marker.id;
    if (k == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(saw_marker);
  EXPECT_LT(got, frames.size());
  EXPECT_GT(b.counters().rx_overflow, 0u);
  EXPECT_EQ(got + b.counters().rx_overflow, frames.size() + 1);
}

TEST(UdpMulticastChannel, SimulatedBusOff) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastChannel a(Opts(TestPort())), b(Opts(TestPort()));
  a.SetSimulatedBusOff(true);
  const CanFrame f = Classic(0x1, {});
  std::size_t sent = 7;
  EXPECT_EQ(a.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kBusOff);
  EXPECT_EQ(sent, 0u);
  EXPECT_EQ(a.counters().bus_state, hal::BusState::kBusOff);
  EXPECT_EQ(a.counters().bus_off_events, 1u);
  ASSERT_EQ(b.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  EXPECT_EQ(ReceiveN(a, 1).size(), 1u);  // still listening
  a.SetSimulatedBusOff(false);
  EXPECT_EQ(a.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  EXPECT_EQ(a.counters().bus_state, hal::BusState::kErrorActive);
  a.Close();
  EXPECT_EQ(a.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kClosed);
  std::array<CanFrame, 1> out;
  EXPECT_EQ(a.Receive(out, &sent), CanStatus::kClosed);
}

TEST(UdpMulticastChannel, NoHeapInSendAndReceive) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  HYQ_REQUIRE_HEAP_HOOKS();
  UdpMulticastChannel a(Opts(TestPort())), b(Opts(TestPort()));
  std::vector<CanFrame> burst;
  for (std::uint32_t i = 0; i < 13; ++i) burst.push_back(Fd(0x180 + i, 16, 1));
  EXPECT_TRUE(testing::RoundTripsWithoutHeap(a, b, burst, 100));
}

TEST(UdpMulticastChannel, OpenErrorsNameTheProblem) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  UdpMulticastOptions o;
  o.group = "10.0.0.1";
  EXPECT_THROW({ UdpMulticastChannel c(o); }, ChannelError);
  o.group = "not-an-address";
  try {
    UdpMulticastChannel c(o);
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_NE(std::string(e.what()).find("not-an-address"), std::string::npos) << e.what();
  }
  o = UdpMulticastOptions{};
  o.ttl = 300;
  EXPECT_THROW({ UdpMulticastChannel c(o); }, ChannelError);
}

TEST(UdpMulticastChannel, OpensFromSpec) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  auto a = OpenChannel("udp:239.74.163.2:" + std::to_string(TestPort()));
  auto b = OpenChannel("udp::" + std::to_string(TestPort()) + ",ttl=0,fd=0,batch=8");
  EXPECT_TRUE(a->fd_enabled());
  EXPECT_FALSE(b->fd_enabled());
  const CanFrame f = Classic(0x42, {4, 2});
  std::size_t sent = 0;
  ASSERT_EQ(a->Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  const auto got = ReceiveN(*b, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(SameFrame(got[0], f));
}

}  // namespace
}  // namespace hyq::drivers::testing

namespace hyq::drivers::testing {
namespace {

TEST(HyqCandumpTool, RecordsAndPlaysTheVirtualBus) {
  HYQ_REQUIRE_PRIVATE_NETNS();
  const std::string spec = "udp::" + std::to_string(TestPort());
  const std::string log = std::filesystem::temp_directory_path().string() + "/hyq_tool_" +
                          std::to_string(getpid()) + ".log";
  const std::vector<CanFrame> frames = {Classic(0x181, {1, 2}), Fd(0x281, 16, 3),
                                        Remote(0x701, 0)};
  {
    testing::Child rec({HYQ_CANDUMP_TOOL, "-o", log, "-L", "vcan0", "-n", "3", "-t", "20", spec},
                       true);
    std::string seen;
    ASSERT_TRUE(rec.WaitForLine("hyq-candump: recording", std::chrono::seconds(10), &seen))
        << seen;
    UdpMulticastChannel tx(Opts(TestPort()));
    std::size_t sent = 0;
    ASSERT_EQ(tx.Send(frames, &sent), CanStatus::kOk);
    EXPECT_EQ(rec.Wait(std::chrono::seconds(20)), 0);
  }
  const CandumpLog recorded = ReadCandumpFile(log);
  ASSERT_EQ(recorded.records.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(SameFrame(recorded.records[i].frame, frames[i]));
    EXPECT_EQ(recorded.records[i].iface_name(), "vcan0");
  }

  UdpMulticastChannel rx(Opts(TestPort()));
  std::string out;
  ASSERT_EQ(testing::RunCommand({HYQ_CANDUMP_TOOL, "--play", log, spec}, &out), 0) << out;
  const auto got = ReceiveN(rx, frames.size());
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i]));
  std::filesystem::remove(log);

  out.clear();
  EXPECT_EQ(testing::RunCommand({HYQ_CANDUMP_TOOL, "bogus:spec"}, &out), 1);
  EXPECT_NE(out.find("channel spec 'bogus:spec'"), std::string::npos) << out;
}

}  // namespace
}  // namespace hyq::drivers::testing
