// The HAL and the device emulator over the drivers' virtual CAN (UDP multicast, four buses, a
// private network namespace): bring-up to OP, then 1 kHz cycles with every input arriving, and
// torque set-points reaching the emulated boards.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "drivers/udp_multicast_channel.h"
#include "hal/hal.h"
#include "tests/drivers/virtual_rig.h"

namespace hyq::testing {
namespace {

TEST(HalOverVirtualBus, BringsUpAndCyclesWithFullWorkingCounter) {
  if (std::getenv("HYQ_NETNS") == nullptr)
    GTEST_SKIP() << "needs a private network namespace for multicast (tests/drivers/in_netns.sh)";
  VirtualRig rig(43313);
  rig.BringUp();
  ASSERT_TRUE(rig.hal->AllIn(hal::DeviceState::kOp)) << rig.hal->BringUpReport(MonotonicNs());
  constexpr int kCycles = 500;
  int wkc_ok = 0, arrived = 0;
  for (int k = 0; k < kCycles; ++k) {
    for (int j = 0; j < hal::kNumJoints; ++j)
      rig.hal->image().commands[static_cast<std::size_t>(j)].torque_Nm = 10.0 + j;
    (void)rig.hal->Write(MonotonicNs());
    // wait for the 13 answers themselves (a loaded machine delays them; 2 s is only a guard)
    if (rig.WaitForInputs(13, 2'000'000'000)) ++arrived;
    if (rig.hal->Read(MonotonicNs()) == hal::HalStatus::kOk && rig.hal->image().wkc.ok()) ++wkc_ok;
  }
  EXPECT_EQ(arrived, kCycles);
  EXPECT_EQ(wkc_ok, kCycles);
  EXPECT_EQ(rig.hal->image().wkc.expected, 13u);
  for (int j = 0; j < hal::kNumJoints; ++j) EXPECT_TRUE(rig.hal->image().joints[j].valid()) << j;
  // the emulator thread has seen the set-points (it reads them on its own thread: stop it first)
  rig.stop = true;
  rig.thread.join();
  rig.thread = std::thread([] {});
  for (int j = 0; j < hal::kNumJoints; ++j)
    EXPECT_DOUBLE_EQ(rig.emulator->torque_setpoint_Nm(j), 10.0 + j) << j;
}

// A datagram on the virtual bus that is no CAN frame is dropped by the driver and counted in the
// HAL's bus counters (driver_dropped), which HYQ_HEALTH publishes per bus (tests/servo/
// servo_loop_test.cc, HealthCarriesTheHalCounters); the cycle goes on with every input.
TEST(HalOverVirtualBus, MalformedDatagramsAreCountedInHealth) {
  if (std::getenv("HYQ_NETNS") == nullptr)
    GTEST_SKIP() << "needs a private network namespace for multicast (tests/drivers/in_netns.sh)";
  constexpr int kPort = 43413;
  VirtualRig rig(kPort);
  rig.BringUp();
  ASSERT_TRUE(rig.hal->AllIn(hal::DeviceState::kOp)) << rig.hal->BringUpReport(MonotonicNs());
  // three datagrams of garbage to bus 1's group and port, from a plain UDP socket
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(kPort + 1);
  inet_pton(AF_INET, drivers::kDefaultUdpGroup, &to.sin_addr);
  const unsigned char junk[7] = {0xde, 0xad, 0xbe, 0xef, 0, 1, 2};
  for (int i = 0; i < 3; ++i)
    ASSERT_EQ(::sendto(fd, junk, sizeof junk, 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(sizeof junk));
  ::close(fd);
  for (int k = 0; k < 50 && rig.hal->bus(1).counters().driver_dropped < 3; ++k) {
    (void)rig.hal->Write(MonotonicNs());
    (void)rig.WaitForInputs(13, 2'000'000'000);
    (void)rig.hal->Read(MonotonicNs());
  }
  EXPECT_EQ(rig.hal->bus(1).counters().driver_dropped, 3u);
  EXPECT_EQ(rig.hal->bus(0).counters().driver_dropped, 0u);
  EXPECT_TRUE(rig.hal->image().wkc.ok());
}

}  // namespace
}  // namespace hyq::testing
