// The HAL and the device emulator over the drivers' virtual CAN (UDP multicast, four buses, a
// private network namespace): bring-up to OP, then 1 kHz cycles with every input arriving, and
// torque set-points reaching the emulated boards.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace hyq::testing
