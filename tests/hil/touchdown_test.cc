// Early and late touchdowns through the whole servo in one process: the daemon's ServoLoop (the
// simulator's configuration: estimator, contact-aware trot, two-stage ID), the HAL and the
// simulated HyQ (MuJoCo, sim/simulated_robot.h) over loopback buses. The left front foot's lane
// has a 3 cm step up ahead of it, or ends in a 3 cm step down (the robot starts on a platform):
// no fault, no fall, and the foot's stance switches when the plant's foot lands, not when the
// gait's clock says.
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "config/servo_config_loader.h"
#include "dynamics/urdf_loader.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"
#include "servo/runtime/servo_loop.h"
#include "sim/simulated_robot.h"
#include "tests/servo/servo_rig.h"

namespace hyq {
namespace {

constexpr std::size_t kLf = 0;
constexpr double kStep = 0.03;

// ServoLoop + HAL + SimulatedRobot on loopback buses, one thread: each Step is the servo's cycle
// (read .. write), then the robot takes the SYNC, steps and answers (what the next cycle reads)
struct ServoSimRig {
  ServoSimRig(servo::ServoConfig cfg, const sim::SimulatedRobotConfig& rc)
      : config(std::move(cfg)), model(dynamics::LoadModelFromUrdf(config.urdf)) {
    std::vector<hal::CanChannel*> m, d;
    for (const hal::BusConfig& b : config.hal.buses) {
      wires.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      m.push_back(&wires.back()->endpoint(0));
      d.push_back(&wires.back()->endpoint(1));
    }
    hal = std::make_unique<hal::Hal>(config.hal, m);
    robot = std::make_unique<sim::SimulatedRobot>(model, config.hal, d, rc);
    (void)robot->PollLockStep();
    loop = std::make_unique<servo::ServoLoop>(config, model, *hal, &sink);
  }
  std::int64_t now() const { return 1'000'000'000 + robot->time_ns(); }
  void BringUpAndStart() {
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now(), [this] {
      (void)robot->PollLockStep();
      return now();
    });
    (void)robot->PollLockStep();
    loop->Start(now());
  }
  void Step() {
    loop->Cycle(now(), 0);
    (void)robot->PollLockStep();
  }

  servo::ServoConfig config;
  dynamics::Model model;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<sim::SimulatedRobot> robot;
  testing::RecordingSink sink;
  std::unique_ptr<servo::ServoLoop> loop;
};

servo::ServoConfig TrotConfig() {
  servo::ServoConfig c = config::LoadServoConfig(testing::SourceDir() / "config/hyq_servo_sim.yaml");
  c.clock = servo::ClockMode::kRealtime;  // one thread: the answers are there at the next read
  c.realtime.enabled = false;
  c.deadline.max_consecutive_misses = 1'000'000;  // the wall clock is not this test's
  c.telemetry.lcm_url.clear();
  c.auto_enable = true;
  c.reference = servo::Reference::Kind::kTrot;
  c.duration_s = 5.0;
  return c;
}

// What happened to the left front foot: each landing the gait saw (its stance flag rising), how
// far it was from the plant's touchdown, and whether the clock had the foot in swing then.
struct Landing {
  double t_s;
  double plant_touch_s;  // the plant's first contact of that landing (-1: none seen)
  servo::FootPhase phase_before;
  bool early;            // the gait's clock said swing
};
struct TouchdownRun {
  std::vector<Landing> landings;
  int reaching_cycles = 0, reaching_in_stance_set = 0, reaching_while_touching = 0;
  bool fault = false, fell = false;
  std::string events;
};

TouchdownRun Trot(const std::vector<sim::GroundBox>& boxes) {
  sim::SimulatedRobotConfig rc;
  rc.plant.boxes = boxes;
  ServoSimRig rig(TrotConfig(), rc);
  rig.BringUpAndStart();
  TouchdownRun out;
  bool was_stance = true, was_touching = true;
  double touch_s = -1.0;
  servo::FootPhase last_phase = servo::FootPhase::kStance;
  for (int k = 0; k < 12000 && !rig.loop->finished(); ++k) {
    rig.Step();
    if (rig.loop->mode() != servo::ServoMode::kActive) continue;
    const auto& c = rig.sink.last.contact;
    const bool touching = rig.robot->plant().FootContacts()[kLf].touching;
    const double t = rig.robot->time_s();
    if (touching && !was_touching) touch_s = t;
    if (!touching) touch_s = touching ? touch_s : -1.0;
    was_touching = touching;
    const auto phase = static_cast<servo::FootPhase>(c.gait_phase[kLf]);
    const bool stance = c.stance_reference[kLf] != 0;
    if (phase == servo::FootPhase::kReaching) {
      ++out.reaching_cycles;
      out.reaching_in_stance_set += stance ? 1 : 0;
    }
    if (stance && !was_stance)
      out.landings.push_back({t, touch_s, last_phase, phase == servo::FootPhase::kLanded});
    was_stance = stance;
    last_phase = phase;
  }
  for (const auto& e : rig.sink.events) {
    out.events += std::string(servo::ToString(e.reason)) + "@" + std::to_string(e.cycle) + "[" +
                  servo::ToString(e.from) + ">" + servo::ToString(e.to) + "]" +
                  (e.reason == servo::EventReason::kOutOfRange ? std::string(" (") + e.detail.data() + ")" : "") +
                  " ";
    if (e.to == servo::ServoMode::kDamping && e.reason != servo::EventReason::kStopRequest) out.fault = true;
    if (e.to == servo::ServoMode::kFault) out.fault = true;
  }
  out.fell = rig.robot->fell();
  return out;
}

void Print(const char* name, const TouchdownRun& r) {
  std::printf("%s: events %s\n", name, r.events.c_str());
  for (const Landing& l : r.landings)
    std::printf("  lf landed at %.3f s (%s, after %s), the plant's touchdown at %.3f s\n", l.t_s,
                l.early ? "early" : "due", servo::ToString(l.phase_before), l.plant_touch_s);
  std::printf("  reaching down late: %d cycles\n", r.reaching_cycles);
}

TEST(Touchdown, AStepUpUnderOneFootLandsItEarlyWhereItTouches) {
  // lf's lane from x = 0.53 m on is 3 cm higher: its second and later landings are on it
  const TouchdownRun r = Trot({{0.53, 2.0, 0.15, 0.7, kStep}});
  Print("step up", r);
  EXPECT_FALSE(r.fault) << r.events;
  EXPECT_FALSE(r.fell);
  int early = 0;
  for (const Landing& l : r.landings) {
    if (!l.early) continue;
    ++early;
    ASSERT_GE(l.plant_touch_s, 0.0) << "the gait saw a landing the plant did not have, at " << l.t_s;
    EXPECT_LE(l.t_s - l.plant_touch_s, 0.03) << "landed late after the plant's touchdown at " << l.t_s;
  }
  EXPECT_GE(early, 2) << "the step up makes lf land before the clock's touchdown";
}

TEST(Touchdown, AStepDownUnderOneFootReachesItDownUntilItTouches) {
  // the robot starts on a 3 cm platform; lf's lane of it ends at x = 0.53 m
  const TouchdownRun r = Trot({{-2.0, 3.0, -1.0, 0.15, kStep}, {-2.0, 0.53, 0.15, 1.0, kStep}});
  Print("step down", r);
  EXPECT_FALSE(r.fault) << r.events;
  EXPECT_FALSE(r.fell);
  EXPECT_GT(r.reaching_cycles, 20) << "lf's stance comes due above the lower ground";
  EXPECT_EQ(r.reaching_in_stance_set, 0) << "a foot reaching down is not in the ID's contact set";
  int late = 0;
  for (const Landing& l : r.landings) {
    if (l.phase_before != servo::FootPhase::kReaching) continue;
    ++late;
    ASSERT_GE(l.plant_touch_s, 0.0) << "the gait saw a landing the plant did not have, at " << l.t_s;
    EXPECT_LE(l.t_s - l.plant_touch_s, 0.03) << "landed late after the plant's touchdown at " << l.t_s;
  }
  EXPECT_GE(late, 1) << "lf lands late, where the lower ground is";
}

}  // namespace
}  // namespace hyq
