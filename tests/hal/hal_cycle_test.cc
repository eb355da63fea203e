// The whole HAL against the device emulator over four loopback buses: bring-up, the process
// image, the working-counter check and the faults the emulator injects.
#include "hal/hal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "tests/hal/hal_fixture.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::hal {
namespace {

using testing::HalRig;

constexpr int kLfKfe = 2, kRhHfe = 10, kLhKfe = 8;

void SetStanding(Emulator& emu) {
  // HyQ's standing posture (SRDF): HAA -0.2, HFE +-0.75, KFE -+1.5; some velocity and torque
  for (int j = 0; j < kNumJoints; ++j) {
    const int leg = j / 3, kind = j % 3;
    const bool front = leg < 2;
    const double q = kind == 0 ? -0.2 : kind == 1 ? (front ? 0.75 : -0.75) : (front ? -1.5 : 1.5);
    emu.SetJointState(j, q, 0.1 * (j - 6), 10.0 + j);
  }
  emu.SetImu({0.01, -0.02, 0.03}, {0.1, 0.2, 9.81});
}

TEST(HalCycle, BringUpToOpAndInputsMatchThePlant) {
  HalRig rig;
  SetStanding(*rig.emu);
  rig.BringUp(DeviceState::kOp);
  EXPECT_TRUE(rig.hal->AllIn(DeviceState::kOp));
  EXPECT_EQ(rig.Step(), HalStatus::kOk);
  EXPECT_EQ(rig.Step(), HalStatus::kOk);
  const ProcessImage& im = rig.hal->image();
  EXPECT_EQ(im.wkc.expected, 13u);
  EXPECT_EQ(im.wkc.received, 13u);
  for (int j = 0; j < kNumJoints; ++j) {
    const JointInput& in = im.joints[static_cast<std::size_t>(j)];
    const JointCalibration& c = rig.config.joints[static_cast<std::size_t>(j)];
    const double count_rad = 2.0 * std::numbers::pi / c.encoder.counts_per_rev;
    const int leg = j / 3, kind = j % 3;
    const bool front = leg < 2;
    const double q = kind == 0 ? -0.2 : kind == 1 ? (front ? 0.75 : -0.75) : (front ? -1.5 : 1.5);
    EXPECT_TRUE(in.valid()) << JointName(j);
    EXPECT_EQ(in.age_cycles, 0u);
    EXPECT_EQ(in.device_state, DeviceState::kOp);
    EXPECT_NEAR(in.position_rad, q, count_rad) << JointName(j);
    EXPECT_NEAR(in.velocity_rad_s, 0.1 * (j - 6), count_rad) << JointName(j);
    // one sensor count through the lever arm (<= 5 cm): well under 1 mN·m
    EXPECT_NEAR(in.torque_Nm, 10.0 + j, 1e-3) << JointName(j);
  }
  EXPECT_TRUE(im.imu.valid());
  EXPECT_NEAR(im.imu.gyro_rad_s[1], -0.02, 1e-6);
  EXPECT_NEAR(im.imu.accel_m_s2[2], 9.81, 1e-6);
  for (std::size_t b = 0; b < rig.hal->num_buses(); ++b) {
    const BusCounters& c = rig.hal->bus(b).counters();
    EXPECT_EQ(c.malformed + c.late + c.duplicate + c.tx_failed + c.bus_off, 0u) << b;
  }
}

TEST(HalCycle, CylinderForceBecomesJointTorqueThroughTheLeverArm) {
  HalRig rig;
  rig.BringUp();
  const double q = 0.4, force_N = 2500.0;
  rig.emu->SetJointSensor(1, q, 0.0, force_N);     // lf_hfe: cylinder
  rig.emu->SetJointSensor(0, -0.1, 0.0, 42.0);     // lf_haa: rotary, N·m
  rig.Steps(2);
  const JointInput& hfe = rig.hal->image().joints[1];
  const double r = LeverArm(rig.config.joints[1].cylinder, hfe.position_rad);
  EXPECT_GT(r, 0.02);
  EXPECT_NEAR(hfe.sensor_value, force_N, 1e-3);
  EXPECT_NEAR(hfe.torque_Nm, force_N * r, 1e-3);
  EXPECT_NEAR(rig.hal->image().joints[0].torque_Nm, 42.0, 1e-4);
}

TEST(HalCycle, TorqueSetPointsReachTheBoardsClampedAndSanitised) {
  HalRig rig;
  rig.BringUp();
  auto controller = [](ProcessImage& im) {
    for (int j = 0; j < kNumJoints; ++j) im.commands[static_cast<std::size_t>(j)].torque_Nm = 5.5 * j - 30.0;
    im.commands[1].torque_Nm = 400.0;  // over the 150 N·m limit
    im.commands[4].torque_Nm = std::numeric_limits<double>::quiet_NaN();
  };
  EXPECT_EQ(rig.Step(controller), HalStatus::kBadCommand);
  for (int j = 0; j < kNumJoints; ++j) {
    if (j == 1 || j == 4) continue;
    EXPECT_TRUE(rig.emu->outputs_enabled(j));
    EXPECT_NEAR(rig.emu->torque_setpoint_Nm(j), 5.5 * j - 30.0, 1e-3) << JointName(j);
  }
  EXPECT_NEAR(rig.emu->torque_setpoint_Nm(1), 150.0, 1e-9);
  EXPECT_EQ(rig.emu->torque_setpoint_Nm(4), 0.0);
  EXPECT_EQ(rig.hal->bus(0).counters().saturated, 1u);
  EXPECT_EQ(rig.hal->bus(1).counters().bad_commands, 1u);
}

// Brings the rig to OP standing, then silences the lf_kfe board (its joint moved, unseen) and
// runs the cycle whose SYNC is the first one it ignores; returns the last valid lf_kfe angle.
double SilenceLfKfe(HalRig& rig) {
  SetStanding(*rig.emu);
  rig.BringUp();
  (void)rig.Step();
  const double q_before = rig.hal->image().joints[kLfKfe].position_rad;
  rig.emu->joint_faults(kLfKfe).silent = true;
  rig.emu->SetJointState(kLfKfe, -1.0, 0.0, 0.0);
  (void)rig.Step();
  return q_before;
}

TEST(HalCycle, SilentDeviceIsFlaggedDropsToSafeOpAndNeedsAnAcknowledgement) {
  HalRig rig;
  const double q_before = SilenceLfKfe(rig);
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);
  const ProcessImage& im = rig.hal->image();
  EXPECT_EQ(im.wkc.expected, 13u);
  EXPECT_EQ(im.wkc.received, 12u);
  const JointInput& kfe = im.joints[kLfKfe];
  EXPECT_EQ(kfe.status, InputStatus::kHeld);
  EXPECT_EQ(kfe.age_cycles, 1u);
  // flagged, not refreshed: the last angle moved on by the last velocity for one period
  EXPECT_NEAR(kfe.position_rad, q_before + 1e-3 * kfe.velocity_rad_s, 1e-12);
  for (int j = 0; j < kNumJoints; ++j)
    if (j != kLfKfe) {
      EXPECT_TRUE(im.joints[static_cast<std::size_t>(j)].valid()) << JointName(j);
    }
  EXPECT_EQ(rig.hal->bus(0).counters().missing, 1u);
  EXPECT_EQ(rig.hal->bus(0).counters().last_fault_node, 3);
  EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kOp) << "up to max_held_cycles tolerated";
  rig.Steps(DefaultHalConfig().timing.max_held_cycles);
  EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kSafeOp);
  EXPECT_EQ(rig.Device(0, 2).error, DeviceError::kInputsLost);
  EXPECT_EQ(im.joints[kLfKfe].device_state, DeviceState::kSafeOp);
  // the board comes back: inputs valid again, but the latched error keeps the outputs safe
  rig.emu->joint_faults(kLfKfe).silent = false;
  rig.Steps(20);
  EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kSafeOp);
  EXPECT_TRUE(im.joints[kLfKfe].valid());
  EXPECT_FALSE(rig.emu->outputs_enabled(kLfKfe));
  rig.hal->AcknowledgeFaults(rig.now_ns);
  rig.Steps(10);
  EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kOp);
  EXPECT_TRUE(rig.emu->outputs_enabled(kLfKfe));
}

// The one late-or-missing policy (docs/hal.md): held and counted for max_held_cycles cycles in a
// row, the next missing one takes the device out of OP; the limit is the configuration's.
TEST(HalCycle, InputsAreHeldForMaxHeldCyclesThenTheDeviceLeavesOp) {
  for (const int limit : {1, 3, 6}) {
    SCOPED_TRACE("max_held_cycles " + std::to_string(limit));
    HalConfig config = DefaultHalConfig();
    config.timing.max_held_cycles = limit;
    HalRig rig(config);
    const double q_before = SilenceLfKfe(rig);
    const JointInput& kfe = rig.hal->image().joints[kLfKfe];
    for (int k = 1; k <= limit; ++k) {
      (void)rig.Step();
      EXPECT_EQ(kfe.status, InputStatus::kHeld) << "cycle " << k;
      EXPECT_EQ(kfe.age_cycles, static_cast<std::uint32_t>(k));
      EXPECT_NEAR(kfe.position_rad, q_before + k * 1e-3 * kfe.velocity_rad_s, 1e-12)
          << "the last valid angle, moved on by the last velocity";
      EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kOp) << "cycle " << k;
    }
    EXPECT_EQ(rig.Device(0, 2).counters.held, static_cast<std::uint64_t>(limit));
    EXPECT_EQ(rig.Device(0, 2).counters.max_held_in_row, static_cast<std::uint32_t>(limit));
    EXPECT_EQ(rig.hal->bus(0).counters().held, static_cast<std::uint64_t>(limit));
    (void)rig.Step();  // one more: past the limit
    EXPECT_EQ(kfe.status, InputStatus::kMissing);
    EXPECT_EQ(rig.Device(0, 2).state, DeviceState::kSafeOp);
    EXPECT_EQ(rig.Device(0, 2).error, DeviceError::kInputsLost);
    EXPECT_EQ(rig.Device(0, 2).counters.held, static_cast<std::uint64_t>(limit))
        << "a missing input past the limit is not a held one";
    for (int j = 0; j < kNumJoints; ++j) {
      if (j != kLfKfe) {
        EXPECT_EQ(rig.Device(j / 3, j % 3).counters.held, 0u) << JointName(j);
      }
    }
  }
}

TEST(HalCycle, LateFrameIsCountedAndNeverUsed) {
  HalRig rig;
  SetStanding(*rig.emu);
  rig.BringUp();
  (void)rig.Step();
  const double q_before = rig.hal->image().joints[kRhHfe].position_rad;
  rig.emu->joint_faults(kRhHfe).delay_syncs = 1;
  rig.emu->SetJointState(kRhHfe, 0.3, 0.0, 0.0);
  (void)rig.Step();
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);  // nothing answered the last SYNC
  const JointInput& in = rig.hal->image().joints[kRhHfe];
  EXPECT_EQ(in.status, InputStatus::kHeld);
  EXPECT_EQ(rig.hal->bus(3).counters().late, 0u);
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);  // now the answer to the SYNC before arrives
  EXPECT_EQ(in.status, InputStatus::kHeld);
  EXPECT_EQ(in.age_cycles, 2u);
  EXPECT_NEAR(in.position_rad, q_before + 2e-3 * in.velocity_rad_s, 1e-12)
      << "the late frame's value was not used (the held angle moves on by the last velocity)";
  EXPECT_EQ(rig.hal->bus(3).counters().late, 1u);
  EXPECT_EQ(rig.Device(3, 1).counters.late, 1u);
  // back on time
  rig.emu->joint_faults(kRhHfe).delay_syncs = 0;
  rig.Steps(2);
  EXPECT_TRUE(rig.hal->image().joints[kRhHfe].valid());
  EXPECT_NEAR(rig.hal->image().joints[kRhHfe].position_rad, 0.3, 1e-4);
}

TEST(HalCycle, DuplicatedFrameBreaksTheWorkingCounter) {
  HalRig rig;
  rig.BringUp();
  rig.emu->joint_faults(kLhKfe).duplicate_next = 1;
  (void)rig.Step();
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);
  const ProcessImage& im = rig.hal->image();
  EXPECT_EQ(im.wkc.expected, 13u);
  EXPECT_EQ(im.wkc.received, 14u);
  EXPECT_EQ(im.joints[kLhKfe].status, InputStatus::kDuplicate);
  EXPECT_EQ(rig.hal->bus(2).counters().duplicate, 1u);
  EXPECT_EQ(rig.Step(), HalStatus::kOk);
  EXPECT_TRUE(im.joints[kLhKfe].valid());
}

TEST(HalCycle, CorruptFrameIsCountedAsMalformedAndTheJointMissing) {
  HalRig rig;
  rig.BringUp();
  rig.emu->joint_faults(0).corrupt_next = 1;
  (void)rig.Step();
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);
  EXPECT_EQ(rig.hal->image().joints[0].status, InputStatus::kHeld);
  EXPECT_EQ(rig.hal->bus(0).counters().malformed, 1u);
  EXPECT_EQ(rig.Device(0, 0).counters.malformed, 1u);
  EXPECT_EQ(rig.Step(), HalStatus::kOk);
}

TEST(HalCycle, ImuDropIsFlagged) {
  HalRig rig;
  rig.BringUp();
  rig.emu->imu_faults().drop_next = 1;
  (void)rig.Step();
  EXPECT_EQ(rig.Step(), HalStatus::kWorkingCounter);
  EXPECT_EQ(rig.hal->image().imu.status, InputStatus::kHeld);
  EXPECT_EQ(rig.Step(), HalStatus::kOk);
  EXPECT_TRUE(rig.hal->image().imu.valid());
}

TEST(HalCycle, EmcyDropsTheDeviceToSafeOpWithItsCode) {
  HalRig rig;
  rig.BringUp();
  rig.emu->SendJointEmcy(4, emcy::kSensor);
  rig.Steps(2);
  const DeviceRuntime& d = rig.Device(1, 1);
  EXPECT_EQ(d.state, DeviceState::kSafeOp);
  EXPECT_EQ(d.error, DeviceError::kEmcy);
  EXPECT_EQ(d.counters.last_emcy_code, emcy::kSensor);
  EXPECT_EQ(rig.hal->bus(1).counters().last_emcy_code, emcy::kSensor);
  EXPECT_EQ(rig.hal->image().joints[4].status, InputStatus::kDeviceFault);
  EXPECT_FALSE(rig.emu->outputs_enabled(4));
  // acknowledging sends the fault reset; the board clears its fault and the joint returns to OP
  rig.hal->AcknowledgeFaults(rig.now_ns);
  rig.Steps(10);
  EXPECT_EQ(d.state, DeviceState::kOp);
  EXPECT_TRUE(rig.emu->outputs_enabled(4));
}

TEST(HalCycle, EmulatorBusOffLosesTheLegAndTheReportSaysWho) {
  HalRig rig;
  rig.BringUp();
  rig.emu->SetBusOff(2, true);
  EXPECT_TRUE(rig.emu->bus_off(2));
  EXPECT_EQ(rig.emu->counters(2).bus_off_events, 1u);
  rig.Steps(DefaultHalConfig().timing.max_held_cycles + 2);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(rig.Device(2, k).state, DeviceState::kSafeOp);
    EXPECT_EQ(rig.hal->image().joints[static_cast<std::size_t>(6 + k)].status, InputStatus::kMissing);
  }
  rig.Steps(400);  // heartbeat consumer timeout (350 ms)
  for (int k = 0; k < 3; ++k) EXPECT_EQ(rig.Device(2, k).state, DeviceState::kInit);
  EXPECT_EQ(rig.Device(2, 0).error, DeviceError::kHeartbeatLost);
  const std::string report = rig.hal->BringUpReport(rig.now_ns);
  EXPECT_NE(report.find("3 of 13 devices not in OP"), std::string::npos) << report;
  EXPECT_NE(report.find("bus 'lh' (can2) node 1 'lh_haa' joint lh_haa_joint: in INIT"),
            std::string::npos) << report;
  EXPECT_NE(report.find("last error: heartbeat lost (first: inputs lost (working counter))"),
            std::string::npos) << report;
  EXPECT_TRUE(rig.hal->bus(0).AllIn(DeviceState::kOp));
  // recovery: the boards answer the HAL's reset and come back up, the error stays latched
  rig.emu->SetBusOff(2, false);
  rig.Steps(50);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(rig.Device(2, k).state, DeviceState::kSafeOp);
  rig.hal->AcknowledgeFaults(rig.now_ns);
  rig.Steps(10);
  EXPECT_TRUE(rig.hal->AllIn(DeviceState::kOp));
}

TEST(HalCycle, InputsAreNanUntilTheFirstFrameAndAReadWithoutWriteExpectsNothing) {
  HalRig rig;
  EXPECT_TRUE(std::isnan(rig.hal->image().joints[0].position_rad));
  EXPECT_TRUE(std::isnan(rig.hal->image().imu.gyro_rad_s[0]));
  rig.BringUp();
  EXPECT_EQ(rig.hal->Read(rig.now_ns), HalStatus::kOk);
  EXPECT_EQ(rig.hal->image().wkc.expected, 13u);
  EXPECT_EQ(rig.hal->Read(rig.now_ns), HalStatus::kOk) << "no SYNC went out: nothing is missing";
  EXPECT_EQ(rig.hal->image().wkc.expected, 0u);
  EXPECT_EQ(rig.hal->bus(0).counters().missing, 0u);
}

TEST(HalCycle, ChannelBusOffIsReported) {
  HalRig rig;
  rig.BringUp();
  rig.wires[1]->SetBusOff(true);
  EXPECT_EQ(rig.Step(), HalStatus::kBusOff);
  EXPECT_GE(rig.hal->bus(1).counters().bus_off, 1u);
  rig.wires[1]->SetBusOff(false);
  rig.Steps(2);
}

TEST(HalCycle, BringUpTimeoutNamesWhoDidNotComeUp) {
  HalConfig cfg = DefaultHalConfig();
  cfg.timing.bringup_timeout_s = 0.2;
  cfg.timing.state_timeout_s = 0.1;
  HalRig rig(cfg);
  rig.emu->joint_faults(kLhKfe).silent = true;
  rig.emu->joint_faults(kRhHfe).refuse_enable = true;
  try {
    rig.BringUp();
    FAIL() << "bring-up should time out";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("2 of 13 devices not in OP"), std::string::npos) << msg;
    EXPECT_NE(msg.find("node 3 'lh_kfe' joint lh_kfe_joint: in INIT, wanted OP; last error: no "
                       "boot-up after NMT reset; no heartbeat"),
              std::string::npos) << msg;
    EXPECT_NE(msg.find("node 2 'rh_hfe' joint rh_hfe_joint: in SAFE-OP, wanted OP; last error: "
                       "enable not confirmed"),
              std::string::npos) << msg;
  }
}

TEST(HalCycle, SafeOpHoldsOutputsSafe) {
  HalRig rig;
  rig.BringUp(DeviceState::kSafeOp);
  auto controller = [](ProcessImage& im) {
    for (auto& c : im.commands) c.torque_Nm = 50.0;
  };
  for (int i = 0; i < 5; ++i) EXPECT_EQ(rig.Step(controller), HalStatus::kOk);
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_TRUE(rig.hal->image().joints[static_cast<std::size_t>(j)].valid());
    EXPECT_FALSE(rig.emu->outputs_enabled(j));
    EXPECT_EQ(rig.emu->torque_setpoint_Nm(j), 0.0);
    EXPECT_GT(rig.emu->rpdos_received(j), 0u) << "SAFE-OP still sends (zero) set-points";
  }
}

TEST(HalCycle, NoHeapInOneWholeCycleWithFourBusesAndTheEmulator) {
  HYQ_REQUIRE_HEAP_HOOKS();
  HalRig rig;
  SetStanding(*rig.emu);
  rig.BringUp();
  for (int i = 0; i < 3; ++i) (void)rig.Step();  // warm-up
  std::int64_t now = rig.now_ns;
  HalStatus read = HalStatus::kOk, write = HalStatus::kOk;
  {
    hyq::testing::NoHeapGuard guard;
    for (int i = 0; i < 10; ++i) {
      read = rig.hal->Read(now);
      for (auto& c : rig.hal->image().commands) c.torque_Nm = 1.0;
      write = rig.hal->Write(now);
      rig.emu->SetJointState(0, 0.1, 0.0, 1.0);
      rig.emu->Poll(now);
      now += testing::kPeriodNs;
    }
    EXPECT_EQ(guard.allocations(), 0u);
  }
  EXPECT_EQ(read, HalStatus::kOk);
  EXPECT_EQ(write, HalStatus::kOk);
  EXPECT_EQ(rig.hal->image().wkc.received, 13u);
}

}  // namespace
}  // namespace hyq::hal
