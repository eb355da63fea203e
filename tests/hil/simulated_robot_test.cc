// The simulated HyQ driven by a HAL master over in-process loopback buses, in lock-step.
#include "sim/simulated_robot.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <span>
#include <stdexcept>
#include <vector>

#include "dynamics/cycle_dynamics.h"
#include "hal/calibration.h"
#include "hal/protocol.h"
#include "tests/hil/hil_rig.h"
#include "tests/support/no_heap_guard.h"
#include "sim/fault_spec.h"
#include "sim/realtime_runner.h"
#include "sim/sync_phase_lock.h"

namespace hyq::testing {
namespace {

using hal::DeviceState;
using hal::InputStatus;

auto Pd() {
  return [](hal::ProcessImage& im) { StandingPd(HilModel(), im); };
}

TEST(SimulatedRobot, BringUpToOpInLockStepReleasesTheHold) {
  LoopbackRig rig;
  EXPECT_TRUE(rig.robot->holding());
  rig.BringUp();
  EXPECT_TRUE(rig.hal->AllIn(DeviceState::kOp)) << rig.hal->BringUpReport(rig.now());
  (void)rig.Cycle(Pd());
  EXPECT_FALSE(rig.robot->holding());
  const auto& c = rig.robot->counters();
  for (std::size_t b = 0; b < rig.cfg.buses.size(); ++b) EXPECT_EQ(c.syncs[b], c.steps) << b;
  EXPECT_EQ(c.lockstep_forced, 0u);
  EXPECT_GE(c.held_steps, 5u);
  for (int i = 0; i < 300; ++i) EXPECT_EQ(rig.Cycle(Pd()), hal::HalStatus::kOk) << i;
  EXPECT_FALSE(rig.robot->fell());
  EXPECT_NEAR(rig.robot->plant().q()(2), HilModel().standing_base_height_m, 0.05);
}

TEST(SimulatedRobot, HalReadsThePlantAnglesWithinOneEncoderCount) {
  LoopbackRig rig;
  rig.BringUp();
  for (int i = 0; i < 200; ++i) {
    // the TPDOs answering this cycle's SYNC carry the state before the step the SYNC triggers
    (void)rig.hal->Read(rig.now());
    StandingPd(HilModel(), rig.hal->image());
    (void)rig.hal->Write(rig.now());
    const dynamics::VectorQ q = rig.robot->plant().q();
    (void)rig.robot->PollLockStep();
    (void)rig.hal->Read(rig.now());
    (void)rig.hal->Write(rig.now());
    (void)rig.robot->PollLockStep();
    for (int j = 0; j < hal::kNumJoints; ++j) {
      const double count = 2 * M_PI / rig.cfg.joints[static_cast<std::size_t>(j)].encoder.counts_per_rev;
      ASSERT_TRUE(rig.hal->image().joints[static_cast<std::size_t>(j)].valid());
      EXPECT_LE(std::abs(rig.hal->image().joints[static_cast<std::size_t>(j)].position_rad - q(7 + j)),
                0.5 * count + 1e-12)
          << "joint " << j << " cycle " << i;
    }
  }
}

std::vector<double> RunTruth(std::uint64_t seed) {
  sim::SimulatedRobotConfig rc = Standing();
  rc.seed = seed;
  rc.profile.load_cell_noise_Nm = 1.0;
  rc.profile.encoder_noise_rad = 1e-4;
  rc.profile.gyro_noise_rad_s = 0.01;
  rc.profile.accel_noise_m_s2 = 0.05;
  LoopbackRig rig(rc);
  std::vector<double> truth;
  rig.robot->SetStepObserver([&](const sim::SimulatedRobot& r) {
    const dynamics::VectorQ q = r.plant().q();
    const dynamics::VectorV v = r.plant().v();
    truth.insert(truth.end(), q.data(), q.data() + q.size());
    truth.insert(truth.end(), v.data(), v.data() + v.size());
    truth.insert(truth.end(), r.applied_torque_Nm().data(), r.applied_torque_Nm().data() + 12);
    truth.insert(truth.end(), r.reported_velocity_rad_s().data(), r.reported_velocity_rad_s().data() + 12);
  });
  rig.BringUp();
  for (int i = 0; i < 500; ++i) (void)rig.Cycle(Pd());
  return truth;
}

TEST(SimulatedRobot, LockStepIsDeterministicBitForBit) {
  const std::vector<double> a = RunTruth(7), b = RunTruth(7), c = RunTruth(8);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 500u * 49);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
  EXPECT_TRUE(a.size() != c.size() || std::memcmp(a.data(), c.data(), a.size() * sizeof(double)) != 0)
      << "another seed gives other sensor noise, hence another run";
}

// The joint velocity the boards report: with `exact` the plant's own velocity, bit for bit (and
// the noise draws are the same either way, so `exact` runs equal the runs made without the
// boards' velocity); by default the boards' (sim/board_velocity.h) from the angles their encoders
// saw. The HAL reads either to 1 count/s.
TEST(SimulatedRobot, JointVelocityIsTheBoardsOrWithExactThePlantsOwn) {
  for (sim::JointVelocity mode : {sim::JointVelocity::kExact, sim::JointVelocity::kBoard}) {
    sim::SimulatedRobotConfig rc = Standing();
    rc.profile.joint_velocity = mode;
    rc.profile.encoder_noise_rad = 1e-4;
    LoopbackRig rig(rc);
    rig.BringUp();
    for (int i = 0; i < 300; ++i) {
      (void)rig.hal->Read(rig.now());
      StandingPd(HilModel(), rig.hal->image());
      (void)rig.hal->Write(rig.now());
      // what the SYNC below is answered with: the sensors of the last step
      const dynamics::VectorJ reported = rig.robot->reported_velocity_rad_s();
      const dynamics::VectorJ expected =
          mode == sim::JointVelocity::kExact
              ? dynamics::VectorJ(rig.robot->plant().v().tail<dynamics::kNumJoints>())
              : rig.robot->board_velocity().velocity_rad_s();
      ASSERT_TRUE(reported == expected) << sim::ToString(mode) << " cycle " << i;
      (void)rig.robot->PollLockStep();
      (void)rig.hal->Read(rig.now());
      (void)rig.hal->Write(rig.now());
      (void)rig.robot->PollLockStep();
      for (int j = 0; j < hal::kNumJoints; ++j) {
        const auto& c = rig.cfg.joints[static_cast<std::size_t>(j)];
        ASSERT_EQ(rig.hal->image().joints[static_cast<std::size_t>(j)].velocity_rad_s,
                  hal::EncoderRateToRadPerSec(c, hal::RadPerSecToEncoderRate(c, reported(j))))
            << sim::ToString(mode) << " cycle " << i << " joint " << j;
      }
    }
    EXPECT_FALSE(rig.robot->fell());
  }
}

// Held on the stand the plant rests exactly, so what the sensors add is the noise alone: its
// sample standard deviation is the configured σ (encoders: with their quantisation, Δ²/12).
TEST(SimulatedRobot, SensorNoiseHasTheConfiguredStandardDeviation) {
  sim::SimulatedRobotConfig rc = Standing();
  rc.seed = 5;
  rc.profile.encoder_noise_rad = 2e-4;
  rc.profile.gyro_noise_rad_s = 0.02;
  rc.profile.accel_noise_m_s2 = 0.05;
  LoopbackRig rig(rc);
  rig.BringUp(DeviceState::kSafeOp);
  const dynamics::VectorJ q_hold = rig.robot->plant().q().tail<dynamics::kNumJoints>();
  const double count = 2 * M_PI / rig.cfg.joints[0].encoder.counts_per_rev;
  double e1 = 0, e2 = 0, g1 = 0, g2 = 0, a1 = 0, a2 = 0;
  long ne = 0, ni = 0;
  const Eigen::Vector3d accel_rest(0, 0, -9.81);  // upside down at rest (ImuAtRest... below)
  for (int i = 0; i < 3000; ++i) {
    (void)rig.Cycle();
    ASSERT_TRUE(rig.robot->holding());
    const sim::ImuReading& r = rig.robot->imu_reported();
    for (int k = 0; k < 3; ++k) {
      g1 += r.gyro_rad_s(k);
      g2 += r.gyro_rad_s(k) * r.gyro_rad_s(k);
      const double a = r.specific_force_m_s2(k) - accel_rest(k);
      a1 += a;
      a2 += a * a;
      ++ni;
    }
    if (i < 5) continue;  // the HAL's image: the answers of the SYNC before
    for (int j = 0; j < hal::kNumJoints; ++j) {
      const double e = rig.hal->image().joints[static_cast<std::size_t>(j)].position_rad - q_hold(j);
      e1 += e;
      e2 += e * e;
      ++ne;
    }
  }
  auto sd = [](double s1, double s2, long n) { return std::sqrt(s2 / n - (s1 / n) * (s1 / n)); };
  EXPECT_NEAR(sd(e1, e2, ne), std::sqrt(2e-4 * 2e-4 + count * count / 12), 0.05 * 2e-4) << ne;
  EXPECT_NEAR(sd(g1, g2, ni), 0.02, 0.05 * 0.02) << ni;
  EXPECT_NEAR(sd(a1, a2, ni), 0.05, 0.05 * 0.05) << ni;
  EXPECT_NEAR(g1 / ni, 0.0, 0.002);
  EXPECT_NEAR(a1 / ni, 0.0, 0.005);
}

// The realistic profile has every sensor's noise, the ideal one none; both the boards' velocity.
TEST(SimulatedRobot, TheRealisticProfileHasSensorNoiseTheIdealNone) {
  const sim::PlantProfile r = sim::PlantProfile::Realistic(), i = sim::PlantProfile::Ideal();
  EXPECT_GT(r.encoder_noise_rad, 0.0);
  EXPECT_GT(r.load_cell_noise_Nm, 0.0);
  EXPECT_GT(r.gyro_noise_rad_s, 0.0);
  EXPECT_GT(r.accel_noise_m_s2, 0.0);
  EXPECT_EQ(i.encoder_noise_rad + i.load_cell_noise_Nm + i.gyro_noise_rad_s + i.accel_noise_m_s2, 0.0);
  EXPECT_EQ(r.joint_velocity, sim::JointVelocity::kBoard);
  EXPECT_EQ(i.joint_velocity, sim::JointVelocity::kBoard);
  EXPECT_EQ(i.velocity_cutoff_hz, sim::kBoardVelocityCutoffHz);
  EXPECT_NE(r.Json().find("\"sensor_noise\": {\"encoder_rad\": 1.2e-05"), std::string::npos) << r.Json();
  EXPECT_EQ(sim::JointVelocityByName("exact", "x"), sim::JointVelocity::kExact);
  EXPECT_THROW((void)sim::JointVelocityByName("fast", "--joint-velocity"), std::invalid_argument);
}

// The emulator answers the buses one after the other within a Poll; a master that has all its
// answers to SYNC k−1 may send cycle k on a bus the Poll has still to read. Those frames wait on
// the wire until the step that SYNC k−1 called for is taken, so SYNC k is answered with the state
// after it and its set-points act from the next step, however the processes interleave.
TEST(SimulatedRobot, FramesArrivingWhileAStepIsDueWaitForTheStep) {
  LoopbackRig rig;
  const std::uint64_t steps = rig.robot->counters().steps;
  const std::uint64_t s0 = rig.robot->counters().syncs[1];
  const hal::CanFrame sync = hal::EncodeSync(1);
  auto send = [&](std::size_t bus) {
    std::size_t sent = 0;
    ASSERT_EQ(rig.wires[bus]->endpoint(0).Send(std::span<const hal::CanFrame>(&sync, 1), &sent),
              hal::CanStatus::kOk);
    ASSERT_EQ(sent, 1u);
  };
  for (std::size_t b = 1; b < 4; ++b) send(b);  // SYNC k−1 on rf, lh, rh; lf's still on its way
  EXPECT_EQ(rig.robot->PollLockStep(), 0);
  send(0);  // lf's SYNC k−1, and already the master's SYNC k on rf
  send(1);
  EXPECT_EQ(rig.robot->PollLockStep(), 1);
  EXPECT_EQ(rig.robot->counters().steps, steps + 1);
  EXPECT_EQ(rig.robot->counters().syncs[1], s0 + 1) << "SYNC k was read before step k−1";
  EXPECT_EQ(rig.wires[1]->endpoint(1).pending(), 1u);
  EXPECT_EQ(rig.robot->PollLockStep(), 0);  // now read, after the step; the others' SYNC k awaited
  EXPECT_EQ(rig.robot->counters().syncs[1], s0 + 2);
  EXPECT_EQ(rig.robot->counters().steps, steps + 1);
}

TEST(SimulatedRobot, ActuatorStepResponseReaches63PercentAtTau) {
  for (double tau : {0.005, 0.02}) {
    sim::SimulatedRobotConfig rc = Standing();
    rc.actuator_tau_s = tau;
    LoopbackRig rig(rc);
    rig.BringUp();
    const int j = 4;  // rf_hfe
    int applied_steps = 0, reached_at = -1;
    for (int i = 0; i < 100 && reached_at < 0; ++i) {
      (void)rig.Cycle([&](hal::ProcessImage& im) {
        for (auto& c : im.commands) c.torque_Nm = 0;
        if (i >= 10) im.commands[j].torque_Nm = 100.0;
      });
      // PollLockStep applied the set-point that came with this SYNC in one step
      if (rig.robot->emulator().torque_setpoint_Nm(j) == 100.0) ++applied_steps;
      if (rig.robot->applied_torque_Nm()(j) >= 100.0 * (1 - std::exp(-1.0))) reached_at = applied_steps;
    }
    const int expected = static_cast<int>(std::lround(tau / rig.cfg.timing.cycle_period_s));
    EXPECT_NEAR(reached_at, expected, 1) << "tau " << tau;
  }
  // rate limit and saturation
  sim::SimulatedRobotConfig rc = Standing();
  rc.actuator_tau_s = 0;
  rc.actuator_rate_limit_Nm_s = 20'000;  // 20 N·m per step
  LoopbackRig rig(rc);
  rig.BringUp();
  for (int i = 0; i < 20; ++i)
    (void)rig.Cycle([](hal::ProcessImage& im) {
      for (auto& c : im.commands) c.torque_Nm = 0;
      im.commands[1].torque_Nm = 1000.0;  // the HAL clamps to 150
    });
  EXPECT_DOUBLE_EQ(rig.robot->applied_torque_Nm()(1), 150.0);
}

TEST(SimulatedRobot, LoadCellNoiseHasTheConfiguredStandardDeviation) {
  sim::SimulatedRobotConfig rc = Standing();
  rc.profile.load_cell_noise_Nm = 2.0;
  rc.seed = 42;
  LoopbackRig rig(rc);
  rig.BringUp();
  double sum = 0, sum2 = 0;
  long n = 0;
  for (int i = 0; i < 1500; ++i) {
    const dynamics::VectorJ applied = rig.robot->applied_torque_Nm();  // what the next SYNC reports
    (void)rig.hal->Read(rig.now());
    StandingPd(HilModel(), rig.hal->image());
    (void)rig.hal->Write(rig.now());
    (void)rig.robot->PollLockStep();
    (void)rig.hal->Read(rig.now());
    for (int j = 0; j < hal::kNumJoints; ++j) {
      const double e = rig.hal->image().joints[static_cast<std::size_t>(j)].torque_Nm - applied(j);
      sum += e;
      sum2 += e * e;
      ++n;
    }
    (void)rig.hal->Write(rig.now());
    (void)rig.robot->PollLockStep();
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(sd, 2.0, 0.1) << n << " samples";
  EXPECT_NEAR(mean, 0.0, 0.1);
}

TEST(SimulatedRobot, ImuAtRestReadsGravityUpsideDownAndNoRotation) {
  // on the stand (held): exactly at rest
  LoopbackRig held;
  held.BringUp(DeviceState::kSafeOp);
  for (int i = 0; i < 5; ++i) (void)held.Cycle();
  const hal::ImuInput& imu = held.hal->image().imu;
  ASSERT_TRUE(imu.valid());
  // the IMU is mounted upside down (rotated by pi about y): +g up reads as -z
  EXPECT_NEAR(imu.accel_m_s2[2], -9.81, 1e-5);
  EXPECT_NEAR(imu.accel_m_s2[0], 0.0, 1e-5);
  EXPECT_NEAR(imu.accel_m_s2[1], 0.0, 1e-5);
  for (double g : imu.gyro_rad_s) EXPECT_NEAR(g, 0.0, 1e-6);
  // standing on its own feet (MuJoCo's accelerometer and gyro at the site): the same, nearly
  sim::SimulatedRobotConfig rc = Standing();
  rc.hold = false;
  LoopbackRig free(rc);
  free.BringUp();
  for (int i = 0; i < 1500; ++i) (void)free.Cycle(Pd());
  const hal::ImuInput& m = free.hal->image().imu;
  ASSERT_TRUE(m.valid());
  EXPECT_NEAR(m.accel_m_s2[2], -9.81, 0.2);
  EXPECT_NEAR(m.accel_m_s2[0], 0.0, 0.2);
  EXPECT_NEAR(m.accel_m_s2[1], 0.0, 0.2);
  for (double g : m.gyro_rad_s) EXPECT_NEAR(g, 0.0, 0.02);
  // a fall is seen: free fall reads ~0 specific force
  EXPECT_FALSE(free.robot->fell());
}

TEST(SimulatedRobot, HoldsOnTheStandUntilEveryBoardIsEnabledAndCommanded) {
  LoopbackRig rig;
  rig.BringUp(DeviceState::kSafeOp);
  for (int i = 0; i < 500; ++i) (void)rig.Cycle();
  EXPECT_TRUE(rig.robot->holding());
  EXPECT_LE((rig.robot->plant().q() - HilModel().StandingQ()).cwiseAbs().maxCoeff(), 1e-12)
      << (rig.robot->plant().q() - HilModel().StandingQ()).transpose();
  hal::Hal& hal = *rig.hal;
  hal.RequestState(DeviceState::kOp, rig.now());
  // enabled at 0 N·m (a daemon in STANDBY): still on the stand
  for (int i = 0; i < 50; ++i) (void)rig.Cycle();
  ASSERT_TRUE(hal.AllIn(DeviceState::kOp)) << hal.BringUpReport(rig.now());
  EXPECT_TRUE(rig.robot->holding());
  int released_after = -1;
  for (int i = 0; i < 100 && released_after < 0; ++i) {
    (void)rig.Cycle(Pd());
    bool all = true;
    for (int j = 0; j < hal::kNumJoints; ++j) all = all && rig.robot->emulator().outputs_enabled(j);
    if (!rig.robot->holding()) {
      EXPECT_TRUE(all);
      released_after = i;
    }
  }
  EXPECT_GE(released_after, 0);
  for (int i = 0; i < 3; ++i) (void)rig.Cycle(Pd());  // the HAL sees the confirmations
  EXPECT_TRUE(hal.AllIn(DeviceState::kOp)) << hal.BringUpReport(rig.now());
}

TEST(SimulatedRobot, EveryFaultKindShowsUpInTheHal) {
  LoopbackRig rig;
  const hal::HalConfig& cfg = rig.cfg;
  for (const char* f : {"0.5:silent:lf_kfe", "0.5:corrupt:rf_hfe:20", "0.5:drop:lh_haa:5",
                        "0.5:nan:lh_kfe", "0.5:bus-off:rh", "0.5:emcy:rf_kfe:0x3100"})
    rig.robot->ScheduleFault(sim::ParseFaultSpec(f, cfg));
  rig.BringUp();
  while (rig.robot->time_s() < 0.45) (void)rig.Cycle(Pd());
  hal::BusCounters before[4];
  for (int b = 0; b < 4; ++b) before[b] = rig.hal->bus(static_cast<std::size_t>(b)).counters();
  while (rig.robot->time_s() < 0.6) (void)rig.Cycle(Pd());
  auto now = [&](int b) { return rig.hal->bus(static_cast<std::size_t>(b)).counters(); };
  EXPECT_EQ(rig.robot->counters().faults_injected, 6u);
  // silent lf_kfe: missing inputs on lf (until the HAL gives the device up), joint 2 not valid
  EXPECT_GE(now(0).missing, before[0].missing + 3);
  EXPECT_NE(rig.hal->image().joints[2].status, InputStatus::kValid);
  EXPECT_NE(rig.hal->image().joints[2].device_state, DeviceState::kOp);
  // corrupt rf_hfe x20: malformed frames on rf
  EXPECT_EQ(now(1).malformed - before[1].malformed, 20u);
  // emcy on rf_kfe
  EXPECT_GT(now(1).emcy, before[1].emcy);
  // drop lh_haa x5 and the broken lh_kfe load cell
  EXPECT_GE(now(2).missing - before[2].missing, 5u);
  const hal::JointInput& lh_kfe = rig.hal->image().joints[8];
  EXPECT_NE(lh_kfe.status_word & hal::status_bit::kSensorFault, 0);
  EXPECT_EQ(lh_kfe.status, InputStatus::kDeviceFault);
  EXPECT_EQ(lh_kfe.effort_counts, hal::kInvalidSensorCounts);
  EXPECT_NE(lh_kfe.device_state, DeviceState::kOp);
  // bus-off rh: nothing from rh any more
  EXPECT_TRUE(rig.robot->emulator().bus_off(3));
  EXPECT_GE(now(3).missing - before[3].missing, 3u * 3);
  for (int j = 9; j < 12; ++j) {
    EXPECT_NE(rig.hal->image().joints[static_cast<std::size_t>(j)].status, InputStatus::kValid);
    EXPECT_NE(rig.hal->image().joints[static_cast<std::size_t>(j)].device_state, DeviceState::kOp);
  }
  // the other joints still fine
  EXPECT_EQ(rig.hal->image().joints[0].status, InputStatus::kValid);
  // lock-step went on: the master's SYNCs reach every bus
  EXPECT_EQ(rig.robot->counters().lockstep_forced, 0u);
}

TEST(SimulatedRobot, FaultSpecErrorsNameWhatWasExpectedAndFound) {
  const hal::HalConfig cfg = HilHalConfig();
  const sim::FaultSpec f = sim::ParseFaultSpec("3.0:corrupt:rf_hfe:20", cfg);
  EXPECT_EQ(f.kind, sim::FaultSpec::Kind::kCorrupt);
  EXPECT_EQ(f.joint, 4);
  EXPECT_EQ(f.count, 20u);
  EXPECT_EQ(sim::ParseFaultSpec("4:bus-off:rh:0.5", cfg).bus, 3);
  EXPECT_EQ(sim::ParseFaultSpec("1:silent:imu", cfg).joint, sim::FaultSpec::kImuTarget);
  EXPECT_EQ(sim::ParseFaultSpec("1:nan:lh_kfe_joint", cfg).joint, 8);
  auto msg = [&](const char* s) {
    try {
      (void)sim::ParseFaultSpec(s, cfg);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(msg("x:silent:lf_kfe").find("expected a time"), std::string::npos);
  EXPECT_NE(msg("1:melt:lf_kfe").find("found 'melt'"), std::string::npos);
  EXPECT_NE(msg("1:silent:lf_xyz").find("found 'lf_xyz'"), std::string::npos);
  EXPECT_NE(msg("1:bus-off:lf_kfe").find("expected a bus lf|rf|lh|rh"), std::string::npos);
  EXPECT_NE(msg("1:drop:lf_kfe:-3").find("frame count"), std::string::npos);
  EXPECT_NE(msg("1:silent").find("T:KIND:TARGET"), std::string::npos);
}

TEST(SimulatedRobot, LockStepCycleDoesNotAllocate) {
  HYQ_REQUIRE_HEAP_HOOKS();
  sim::SimulatedRobotConfig rc = Standing();
  rc.profile.load_cell_noise_Nm = 1.0;
  rc.profile.gyro_noise_rad_s = 0.01;
  LoopbackRig rig(rc);
  rig.BringUp(DeviceState::kSafeOp);  // held on the stand: the hold path
  {
    NoHeapGuard guard;
    for (int i = 0; i < 50; ++i) (void)rig.Cycle();
    EXPECT_EQ(guard.allocations(), 0u);
  }
  EXPECT_TRUE(rig.robot->holding());
  rig.hal->RequestState(DeviceState::kOp, rig.now());
  for (int i = 0; i < 40; ++i) (void)rig.Cycle(Pd());
  ASSERT_FALSE(rig.robot->holding());
  {
    NoHeapGuard guard;
    for (int i = 0; i < 200; ++i) {
      (void)rig.hal->Read(rig.now());
      StandingPd(HilModel(), rig.hal->image());
      (void)rig.hal->Write(rig.now());
      (void)rig.robot->PollLockStep();
    }
    EXPECT_EQ(guard.allocations(), 0u);
  }
}

TEST(SimulatedRobot, RealTimeModeStepsAtTheCyclePeriodOnTheMonotonicClock) {
  LoopbackRig rig;
  std::atomic<bool> stop{false};
  const std::int64_t t0 = MonotonicNs();
  sim::RealtimeRunner runner(rig.robot.get());
  const std::uint64_t steps = runner.Run(stop, 0.2);
  const double wall = 1e-9 * static_cast<double>(MonotonicNs() - t0);
  EXPECT_EQ(steps, 200u);
  // physics follows the wall clock: never ahead of it (a loaded test machine may make it late,
  // which the overrun counter shows; lateness is the benchmark's business, not this test's)
  EXPECT_GE(wall, 0.2 - 1e-3) << "physics ran ahead of the wall clock";
  EXPECT_LT(wall, 0.2 + 0.01 * static_cast<double>(runner.counters().overruns) + 0.5);
  EXPECT_TRUE(rig.robot->holding()) << "no master: still on its stand";
}

// real time: the physics steps lock to the master's SYNC (sim/sync_phase_lock.h)
TEST(SyncPhaseLock, ErrorIsTheDeadlinesOffsetFromSyncPlusPhaseWrappedIntoHalfAPeriod) {
  const sim::SyncPhaseLock lock{.period_ns = 1'000'000, .phase_ns = 500'000};
  const std::int64_t sync = 7'000'123'456;
  for (std::int64_t k : {-3, 0, 1, 40})
    for (std::int64_t e : {-500'000, -499'999, -120'000, 0, 1, 250'000, 499'999}) {
      EXPECT_EQ(lock.Error(sync + 500'000 + k * 1'000'000 + e, sync), e) << k << " " << e;
    }
  // half a period late is half a period early
  EXPECT_EQ(lock.Error(sync + 500'000 + 500'000, sync), -500'000);
}

TEST(SyncPhaseLock, DeadlinesFromAnyStartingPhaseSettleAtThePhaseDespiteJitter) {
  const std::int64_t P = 1'000'000;
  const sim::SyncPhaseLock lock{.period_ns = P, .phase_ns = 500'000};
  for (std::int64_t start = 0; start < P; start += 50'000) {
    std::int64_t due = 3'000'000'000 + start;  // the first deadline, at any phase
    std::int64_t worst_late = 0;
    for (int k = 0; k < 200; ++k) {
      // the master's SYNC k, seen with a wake-up jitter of up to 40 µs (deterministic)
      const std::int64_t sync = 3'000'000'000 + k * P + ((k * 7919) % 5) * 10'000;
      if (sync > due) continue;  // this SYNC comes after the deadline: the next step sees it
      const std::int64_t c = lock.Correction(due + P, sync, due);
      ASSERT_LE(std::abs(c), lock.max_slew_ns);
      due += P + c;
      if (k >= 60) worst_late = std::max(worst_late, std::abs(lock.Error(due, sync)));
    }
    EXPECT_LE(worst_late, 60'000) << "start phase " << start << " ns: not locked after 60 steps";
  }
}

TEST(SyncPhaseLock, OneLateSyncMovesTheDeadlinesLittleAndNoMasterLeavesThemFree) {
  const std::int64_t P = 1'000'000;
  const sim::SyncPhaseLock lock{.period_ns = P, .phase_ns = 500'000};
  const std::int64_t due = 9'000'500'000;  // locked to SYNCs at 9'000'000'000 + k P
  EXPECT_EQ(lock.Correction(due, 9'000'000'000 - P, due - 300'000), 0);
  // the master's SYNC 300 µs late (a stall): a quarter of it would be 75 µs; at most max_slew_ns
  EXPECT_EQ(lock.Correction(due, 9'000'000'000 - P + 300'000, due - 100'000), lock.max_slew_ns);
  // 900 µs late reads as 100 µs early (wrapped), a quarter of it back
  EXPECT_EQ(lock.Correction(due, 9'000'000'000 - P + 900'000, due - 100'000), -25'000);
  // no SYNC yet, the last one too old (the master died), or the lock off: free
  EXPECT_EQ(lock.Correction(due + 300'000, 0, due), 0);
  EXPECT_EQ(lock.Correction(due + 300'000, due - lock.max_sync_age_ns - 1, due), 0);
  const sim::SyncPhaseLock off{.period_ns = P, .phase_ns = -1};
  EXPECT_EQ(off.Correction(due + 300'000, due - P, due), 0);
}

// by default the robot starts in its resting crouch (feet on the ground under their
// standing places, base at 0.40 m), which the daemon stands up from
TEST(SimulatedRobot, StartsRestingInACrouchWithTheFeetOnTheGround) {
  LoopbackRig rig(sim::SimulatedRobotConfig{});
  EXPECT_TRUE(rig.robot->holding());
  const dynamics::VectorQ q = rig.robot->plant().q();
  EXPECT_NEAR(q(2), 0.40, 1e-12);
  auto dyn = std::make_unique<dynamics::CycleDynamics>();
  ASSERT_EQ(dynamics::ComputeCycleDynamics(HilModel(), q, dynamics::VectorV::Zero(), dyn.get()),
            dynamics::DynamicsStatus::kOk);
  auto standing = std::make_unique<dynamics::CycleDynamics>();
  ASSERT_EQ(dynamics::ComputeCycleDynamics(HilModel(), HilModel().StandingQ(),
                                           dynamics::VectorV::Zero(), standing.get()),
            dynamics::DynamicsStatus::kOk);
  for (int f = 0; f < 4; ++f) {
    const auto i = static_cast<std::size_t>(f);
    EXPECT_NEAR(dyn->feet.p_WF_W[i].z(), HilModel().feet[i].radius_m, 1e-6) << f;
    // under the standing posture's footholds (x, y)
    EXPECT_NEAR((dyn->feet.p_WF_W[i] - standing->feet.p_WF_W[i]).head<2>().norm(), 0.0, 1e-6) << f;
  }
  EXPECT_FALSE(rig.robot->fell());
  EXPECT_FALSE(rig.robot->sat_down());
}

}  // namespace
}  // namespace hyq::testing
