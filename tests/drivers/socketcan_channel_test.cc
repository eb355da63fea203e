// SocketCAN on vcan: run by run_vcan_tests.sh inside ../shared/tools/run-in-vcan-vm (a Debian
// kernel with vcan0..vcanN up) or natively where the kernel has CAN. HYQ_VCAN_MODE=classic|fd
// says whether the vcan interfaces were created with MTU 16 or 72. Every case skips, saying why,
// when this kernel has no AF_CAN.
#include "drivers/socketcan_channel.h"

#include <gtest/gtest.h>
#include <linux/can/error.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "drivers/candump.h"
#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "drivers/socket_util.h"
#include "tests/drivers/test_util.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::drivers::testing {
namespace {

using hal::BusState;
using hal::CanFrame;
using hal::CanStatus;

bool FdMode() {
  const char* m = std::getenv("HYQ_VCAN_MODE");
  return m != nullptr && std::string(m) == "fd";
}

#define HYQ_REQUIRE_SOCKETCAN()                                                               \
  do {                                                                                        \
    if (!KernelHasSocketCan())                                                                \
      GTEST_SKIP() << "this kernel has no AF_CAN (CONFIG_CAN unset); run through "            \
                      "tests/drivers/run_vcan_tests.sh, which uses ../shared/tools/"          \
                      "run-in-vcan-vm";                                                       \
  } while (false)

SocketCanOptions On(const std::string& iface) {
  SocketCanOptions o;
  o.interface = iface;
  return o;
}

TEST(SocketCan, OpensWithTheInterfaceFdMode) {
  HYQ_REQUIRE_SOCKETCAN();
  SocketCanChannel a(On("vcan0"));
  EXPECT_EQ(a.fd_enabled(), FdMode());
  EXPECT_EQ(a.name(), "socketcan:vcan0");
  auto via_spec = OpenChannel("socketcan-classic:vcan0");
  EXPECT_FALSE(via_spec->fd_enabled());
  if (FdMode()) {
    EXPECT_TRUE(OpenChannel("socketcan-fd:vcan1")->fd_enabled());
  } else {
    try {
      (void)OpenChannel("socketcan-fd:vcan1");
      FAIL() << "socketcan-fd on a classic interface must throw";
    } catch (const ChannelError& e) {
      EXPECT_NE(std::string(e.what()).find("found MTU 16"), std::string::npos) << e.what();
    }
  }
  try {
    (void)OpenChannel("socketcan:nosuchcan7");
    FAIL();
  } catch (const ChannelError& e) {
    EXPECT_NE(std::string(e.what()).find("no such interface 'nosuchcan7'"), std::string::npos)
        << e.what();
  }
}

TEST(SocketCan, ClassicFramesBetweenTwoSockets) {
  HYQ_REQUIRE_SOCKETCAN();
  SocketCanChannel a(On("vcan0")), b(On("vcan0")), other(On("vcan1"));
  const std::vector<CanFrame> frames = {Classic(0x181, {1, 2, 3, 4, 5, 6, 7, 8}), Classic(0, {}),
                                        Classic(0x1ABCDEF0, {9}, true), Remote(0x701, 1),
                                        Remote(0x18DAF110, 8, true)};
  const std::int64_t before = internal::RealtimeNs();
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  ASSERT_EQ(sent, frames.size());
  const auto got = ReceiveN(b, frames.size());
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(SameFrame(got[i], frames[i]));
    EXPECT_GE(got[i].timestamp_ns, before);
    EXPECT_LE(got[i].timestamp_ns, internal::RealtimeNs());
  }
  EXPECT_EQ(Drain(a), 0u) << "a socket does not receive its own frames";
  EXPECT_EQ(Drain(other), 0u) << "vcan1 is another bus";
  EXPECT_EQ(a.counters().tx_frames, frames.size());
  EXPECT_EQ(b.counters().rx_frames, frames.size());
}

TEST(SocketCan, FdFrames) {
  HYQ_REQUIRE_SOCKETCAN();
  SocketCanChannel a(On("vcan0")), b(On("vcan0"));
  const std::vector<CanFrame> frames = {Fd(0x281, 64, 1, true, false), Fd(0x282, 0, 0),
                                        Fd(0x1F000283, 12, 3, false, true, true),
                                        Classic(0x284, {4})};
  std::size_t sent = 0;
  if (!FdMode()) {
    EXPECT_EQ(a.Send(frames, &sent), CanStatus::kBadFrame);
    EXPECT_EQ(sent, 0u);
    EXPECT_EQ(a.counters().bad_frames, 1u);
    GTEST_SKIP() << "classic vcan (MTU 16): FD frames are refused with kBadFrame, as checked";
  }
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  const auto got = ReceiveN(b, frames.size());
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i]));
  // a classic socket on the same FD bus does not see the FD frames
  SocketCanOptions classic = On("vcan0");
  classic.fd = FdMode::kOff;
  SocketCanChannel c(classic);
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  const auto only_classic = ReceiveN(c, 1);
  ASSERT_EQ(only_classic.size(), 1u);
  EXPECT_EQ(only_classic[0].id, 0x284u);
}

TEST(SocketCan, ErrorFramesAndBusOff) {
  HYQ_REQUIRE_SOCKETCAN();
  // vcan has no controller: an error frame written by one socket reaches every socket whose
  // CAN_RAW_ERR_FILTER matches, exactly like a controller's report
  SocketCanChannel controller(On("vcan0")), node(On("vcan0"));
  const auto inject = [&](const CanFrame& f) {
    std::size_t sent = 0;
    ASSERT_EQ(controller.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
    ASSERT_EQ(ReceiveN(node, 1).size(), 1u);
  };
  inject(Error(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_WARNING, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node.counters().bus_state, BusState::kErrorWarning);
  inject(Error(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_PASSIVE, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node.counters().bus_state, BusState::kErrorPassive);
  inject(Error(CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node.counters().bus_state, BusState::kBusOff);
  EXPECT_EQ(node.counters().bus_off_events, 1u);
  const CanFrame f = Classic(0x1, {});
  std::size_t sent = 9;
  EXPECT_EQ(node.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kBusOff);
  EXPECT_EQ(sent, 0u);
  inject(Error(CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0}));  // still off: not a new event
  EXPECT_EQ(node.counters().bus_off_events, 1u);
  inject(Error(CAN_ERR_RESTARTED, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node.counters().bus_state, BusState::kErrorActive);
  EXPECT_EQ(node.Send(std::span<const CanFrame>(&f, 1), &sent), CanStatus::kOk);
  inject(Error(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_OVERFLOW, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(node.counters().rx_overflow, 1u);
  EXPECT_EQ(node.counters().error_frames, 6u);
}

TEST(SocketCan, BatchesKeepOrder) {
  HYQ_REQUIRE_SOCKETCAN();
  SocketCanOptions o = On("vcan0");
  o.batch = 7;
  o.receive_buffer_bytes = 1 << 20;
  SocketCanChannel a(o), b(o);
  std::vector<CanFrame> frames;
  for (std::uint32_t i = 0; i < 300; ++i) frames.push_back(Classic(i, {static_cast<std::uint8_t>(i)}));
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  ASSERT_EQ(sent, frames.size());
  const auto got = ReceiveN(b, frames.size(), std::chrono::seconds(10), 50);
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i]));
}

TEST(SocketCan, ReceiveOverflowIsCounted) {
  HYQ_REQUIRE_SOCKETCAN();
  SocketCanOptions tiny = On("vcan0");
  tiny.receive_buffer_bytes = 1;  // the kernel's minimum: a handful of frames
  SocketCanChannel a(On("vcan0")), b(tiny);
  const std::vector<CanFrame> frames(300, Classic(0x100, {1, 2, 3, 4, 5, 6, 7, 8}));
  std::size_t sent = 0;
  ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
  std::size_t got = Drain(b);
  ASSERT_EQ(a.Send(std::span<const CanFrame>(frames.data(), 1), &sent), CanStatus::kOk);
  got += ReceiveN(b, 1).size();
  EXPECT_LT(got, frames.size());
  EXPECT_GT(b.counters().rx_overflow, 0u);
  EXPECT_EQ(got + b.counters().rx_overflow, frames.size() + 1);
}

TEST(SocketCan, NoHeapInSendAndReceive) {
  HYQ_REQUIRE_SOCKETCAN();
  HYQ_REQUIRE_HEAP_HOOKS();
  SocketCanChannel a(On("vcan0")), b(On("vcan0"));
  std::vector<CanFrame> burst;
  for (std::uint32_t i = 0; i < 13; ++i)
    burst.push_back(FdMode() ? Fd(0x180 + i, 16, 1) : Classic(0x180 + i, {1, 2, 3, 4}));
  EXPECT_TRUE(testing::RoundTripsWithoutHeap(a, b, burst, 20));
}

TEST(SocketCan, CanUtilsCandumpRecordsUsAndCanplayerPlaysOurLog) {
  HYQ_REQUIRE_SOCKETCAN();
  if (access("/usr/bin/candump", X_OK) != 0 || access("/usr/bin/canplayer", X_OK) != 0)
    GTEST_SKIP() << "can-utils not installed (scripts/bootstrap.sh installs it)";
  std::vector<CanFrame> frames = {Classic(0x181, {1, 2, 3}), Classic(0x1ABCDEF0, {4}, true),
                                  Remote(0x702, 2), Error(CAN_ERR_CRTL, {0, 4, 0, 0, 0, 0, 0, 0})};
  if (FdMode()) frames.push_back(Fd(0x281, 24, 7, true, false));
  const std::string dir = std::filesystem::temp_directory_path().string();
  const std::string theirs = dir + "/hyq_candump.log", ours = dir + "/hyq_ours.log";

  // candump -L records what our channel sends on vcan2; our reader reads its log. Waits on what
  // candump wrote, not on a guessed time (a fixed wait is never enough on a busy machine): a marker
  // frame goes out until candump has recorded it (it is bound then), then the frames, until
  // they are all in its log (30 s guards).
  const CanFrame marker = Classic(0x7EE, {0xAA});
  const auto lines_in = [&] {
    std::ifstream in(theirs);
    std::size_t n = 0;
    for (std::string line; std::getline(in, line);) n += !line.empty();
    return n;
  };
  std::size_t markers = 0;
  {
    std::filesystem::remove(theirs);
    testing::Child candump({"/bin/sh", "-c", "exec /usr/bin/candump -L vcan2,0:0,#FFFFFFFF > " +
                                                 theirs + " 2>&1"});
    SocketCanChannel a(On("vcan2"));
    std::size_t sent = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (lines_in() == 0 && std::chrono::steady_clock::now() < end) {
      ASSERT_EQ(a.Send({&marker, 1}, &sent), CanStatus::kOk);
      ++markers;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // markers still in flight
    const std::size_t before = lines_in();
    ASSERT_GT(before, 0u) << "candump recorded nothing within 30 s";
    ASSERT_EQ(a.Send(frames, &sent), CanStatus::kOk);
    while (lines_in() < before + frames.size() && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    candump.Signal(SIGINT);
    candump.Wait(std::chrono::seconds(10));
  }
  CandumpLog log = ReadCandumpFile(theirs);
  std::size_t first = 0;
  while (first < log.records.size() && SameFrame(log.records[first].frame, marker)) ++first;
  ASSERT_EQ(log.records.size() - first, frames.size()) << markers << " marker(s) sent";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(SameFrame(log.records[first + i].frame, frames[i])) << i;
    EXPECT_EQ(log.records[first + i].iface_name(), "vcan2");
  }

  // canplayer plays our writer's log onto vcan3, where our channel receives it
  {
    CandumpWriter w(ours, "can0");
    ASSERT_TRUE(testing::WriteLog(w, frames));
  }
  SocketCanChannel rx(On("vcan3"));
  std::string out;
  ASSERT_EQ(testing::RunCommand({"/usr/bin/canplayer", "-I", ours, "vcan3=can0"}, &out), 0) << out;
  const auto got = ReceiveN(rx, frames.size());
  ASSERT_EQ(got.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(SameFrame(got[i], frames[i])) << i;
}

}  // namespace
}  // namespace hyq::drivers::testing
