// A stall of the master in lock-step (hyq-sim --fault T:stall:daemon:S): the plant steps on for
// the stall without the master's SYNCs, the boards holding their last set-points until their own
// timer (timing.device_setpoint_timeout_s) trips them, then the plant's clock frame tells the
// master the periods it lost; the master's lock-step channel takes it out before the HAL, and
// the daemon's deadline monitor counts those periods as misses in a row, a deadline_miss fault
// even where lock-step misses are otherwise only counted.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include "hal/lockstep_channel.h"
#include "hal/loopback_bus.h"
#include "hal/protocol.h"
#include "servo/runtime/deadline_monitor.h"
#include "sim/fault_spec.h"
#include "tests/hil/hil_rig.h"

namespace hyq::sim {
namespace {

// a loopback endpoint behind a LockstepChannel, which owns what it wraps
class Borrowed final : public hal::CanChannel {
 public:
  explicit Borrowed(hal::CanChannel* c) : c_(c) {}
  hal::CanStatus Send(std::span<const hal::CanFrame> f, std::size_t* sent) noexcept override {
    return c_->Send(f, sent);
  }
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* n) noexcept override {
    return c_->Receive(out, n);
  }
  const hal::CanCounters& counters() const noexcept override { return c_->counters(); }
  bool fd_enabled() const noexcept override { return c_->fd_enabled(); }
  std::string_view name() const noexcept override { return c_->name(); }

 private:
  hal::CanChannel* c_;
};

// the HAL on lock-step channels (as hyq-servod in lock-step) and the simulated robot, one thread
struct StallRig {
  explicit StallRig(const char* fault) : cfg(testing::HilHalConfig()) {
    std::vector<hal::CanChannel*> m, d;
    for (const hal::BusConfig& b : cfg.buses) {
      wires.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      master.push_back(std::make_unique<hal::LockstepChannel>(
          std::make_unique<Borrowed>(&wires.back()->endpoint(0))));
      m.push_back(master.back().get());
      d.push_back(&wires.back()->endpoint(1));
    }
    hal = std::make_unique<hal::Hal>(cfg, m);
    robot = std::make_unique<SimulatedRobot>(testing::HilModel(), cfg, d, testing::Standing());
    robot->ScheduleFault(ParseFaultSpec(fault, cfg));
    robot->SetStepObserver([this](const SimulatedRobot& r) {
      Applied a;
      for (int j = 0; j < hal::kNumJoints; ++j) {
        a.setpoint_Nm[static_cast<std::size_t>(j)] = r.BoardSetpoints().tau[static_cast<std::size_t>(j)];
        a.enabled[static_cast<std::size_t>(j)] = r.BoardSetpoints().enabled[static_cast<std::size_t>(j)];
      }
      steps.push_back(a);
    });
    (void)robot->PollLockStep();
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now, [this] {
      (void)robot->PollLockStep();
      now += 1'000'000;
      return now;
    });
  }
  // one master cycle (Read, PD, Write), then the robot answers and steps; returns its steps
  int Cycle() {
    (void)hal->Read(now);
    testing::StandingPd(testing::HilModel(), hal->image());
    (void)hal->Write(now);
    now += 1'000'000;
    return robot->PollLockStep();
  }
  // what the daemon's lock-step wait sees (it pumps the channels for the answers)
  std::uint32_t StalledSeen() {
    std::uint32_t n = 0;
    for (const auto& c : master) {
      (void)c->Pump();
      n = std::max(n, c->plant_stalled_steps());
    }
    return n;
  }
  struct Applied {
    std::array<double, hal::kNumJoints> setpoint_Nm{};
    std::array<bool, hal::kNumJoints> enabled{};
  };

  hal::HalConfig cfg;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires;
  std::vector<std::unique_ptr<hal::LockstepChannel>> master;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<SimulatedRobot> robot;
  std::vector<Applied> steps;  // the boards' set-points each step went with
  std::int64_t now = 1'000'000'000;
};

// A stall shorter than the boards' own timer (8 ms): every board holds its set-point through it.
TEST(DaemonStall, ThePlantStepsOnWithTheLastSetpointsAndTheMasterLearnsThePeriods) {
  StallRig rig("0.3:stall:daemon:0.005");
  while (rig.robot->time_s() < 0.3 - 1e-9) (void)rig.Cycle();
  const SetpointFrame held = rig.robot->BoardSetpoints();
  const std::size_t first = rig.steps.size();
  const std::uint64_t syncs = rig.robot->counters().syncs[0];
  std::vector<std::uint64_t> missing;
  for (std::size_t b = 0; b < rig.cfg.buses.size(); ++b)
    missing.push_back(rig.hal->bus(b).counters().missing);
  // the master's next cycle: the stall's 5 steps, then the step of its SYNC
  EXPECT_EQ(rig.Cycle(), 5 + 1);
  EXPECT_EQ(rig.robot->counters().stalled_steps, 5u);
  EXPECT_NEAR(rig.robot->time_s(), 0.306, 1e-9);
  ASSERT_EQ(rig.steps.size(), first + 6);
  for (std::size_t s = first; s < first + 5; ++s)
    for (std::size_t j = 0; j < hal::kNumJoints; ++j) {
      EXPECT_EQ(rig.steps[s].setpoint_Nm[j], held.tau[j]) << s << ' ' << j;
      EXPECT_TRUE(rig.steps[s].enabled[j]) << s << ' ' << j;
    }
  for (int j = 0; j < hal::kNumJoints; ++j) EXPECT_EQ(rig.robot->emulator().setpoint_trip_ns(j), -1);
  // the plant's clock frame: on every bus, taken out before the HAL
  EXPECT_EQ(rig.StalledSeen(), 5u);
  for (const auto& c : rig.master) EXPECT_EQ(c->plant_stalled_steps(), 5u);
  (void)rig.hal->Read(rig.now);
  for (std::size_t b = 0; b < rig.cfg.buses.size(); ++b) {
    EXPECT_EQ(rig.hal->bus(b).counters().unknown, 0u) << b;
    EXPECT_EQ(rig.hal->bus(b).counters().missing, missing[b]) << b;  // every answer came
  }
  // and from then on one step per SYNC again
  for (int i = 0; i < 20; ++i) EXPECT_EQ(rig.Cycle(), 1) << i;
  EXPECT_EQ(rig.robot->counters().steps, rig.robot->counters().syncs[0] + 5);
  EXPECT_EQ(rig.robot->counters().syncs[0], syncs + 21);
  EXPECT_EQ(rig.robot->counters().faults_injected, 1u);
}

// Over 19 ms without a SYNC a board's own timer trips it (as HyQ's boards: timing.
// device_setpoint_timeout_s, 8 ms): 8 steps with the held set-points, then 0 N·m, EMCY 0x8250,
// PRE-OPERATIONAL, for the rest of the stall.
TEST(DaemonStall, OverNineteenMillisecondsTheBoardsTripOnTheirOwnTimer) {
  StallRig rig("0.3:stall:daemon:0.019");
  while (rig.robot->time_s() < 0.3 - 1e-9) (void)rig.Cycle();
  const SetpointFrame held = rig.robot->BoardSetpoints();
  const std::size_t first = rig.steps.size();
  EXPECT_EQ(rig.Cycle(), 19 + 1);
  EXPECT_EQ(rig.StalledSeen(), 19u);
  for (std::size_t s = first; s < first + 19; ++s)
    for (std::size_t j = 0; j < hal::kNumJoints; ++j) {
      const bool holds = s < first + 8;
      EXPECT_EQ(rig.steps[s].setpoint_Nm[j], holds ? held.tau[j] : 0.0) << s - first << ' ' << j;
      EXPECT_EQ(rig.steps[s].enabled[j], holds) << s - first << ' ' << j;
    }
  for (int j = 0; j < hal::kNumJoints; ++j) {
    EXPECT_EQ(rig.robot->emulator().setpoint_trip_delay_ns(j), 9'000'000) << j;
    EXPECT_EQ(rig.robot->emulator().nmt_state(j), hal::NmtState::kPreOperational) << j;
  }
  (void)rig.hal->Read(rig.now);
  EXPECT_EQ(rig.hal->bus(0).counters().last_emcy_code, hal::emcy::kRpdoTimeout);
}

// What the daemon makes of the plant's clock: the lost periods are misses in a row, a fault at
// the limit although lock-step misses are otherwise only counted (stop_in_lockstep false); the
// next cycle that fits starts the count again. A stall shorter than the limit is counted only.
TEST(DaemonStall, TheDeadlineMonitorCountsTheLostPeriodsAsMissesInARow) {
  StallRig rig("0.3:stall:daemon:0.019");
  while (rig.robot->time_s() < 0.31) (void)rig.Cycle();
  const servo::DeadlineConfig config{.budget_fraction = 0.9, .max_consecutive_misses = 5};
  servo::DeadlineMonitor m(config, 1e-3, /*enforce=*/false);
  EXPECT_FALSE(m.Observe(100'000, 100'000));
  m.AddStall(rig.StalledSeen());
  const servo::Fault f = m.Observe(100'000, 100'000);
  ASSERT_TRUE(f);
  EXPECT_EQ(f.reason, servo::EventReason::kDeadlineMiss);
  EXPECT_STREQ(f.detail.data(),
               "19 consecutive deadline misses (19 periods lost to a stall, budget 900.0 us)");
  EXPECT_EQ(m.misses(), 19u);
  EXPECT_EQ(m.max_consecutive(), 19u);
  EXPECT_EQ(m.consecutive(), 0u);  // that cycle fitted
  EXPECT_FALSE(m.Observe(100'000, 100'000));
  m.AddStall(4);
  EXPECT_FALSE(m.Observe(100'000, 100'000));
  EXPECT_EQ(m.misses(), 23u);
  // a slow cycle right after a stall: one more in the row
  m.AddStall(4);
  const servo::Fault g = m.Observe(950'000, 950'000);
  ASSERT_TRUE(g);
  EXPECT_NE(std::strstr(g.detail.data(), "5 consecutive deadline misses (4 periods lost"), nullptr)
      << g.detail.data();
  EXPECT_EQ(m.consecutive(), 5u);
}

}  // namespace
}  // namespace hyq::sim
