// Test rigs for the simulated HyQ: a HAL master driving a SimulatedRobot in lock-step, either in
// one thread over in-process loopback buses (LoopbackRig) or over UDP-multicast virtual buses
// (UdpMaster: only the master; the robot runs in another thread or in the hyq-sim process).
#pragma once

#include <poll.h>

#include <cmath>
#include <functional>

#include <memory>
#include <string>
#include <vector>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "dynamics/urdf_loader.h"
#include "hal/clock.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"
#include "tests/drivers/virtual_rig.h"
#include "sim/simulated_robot.h"

namespace hyq::testing {

inline const dynamics::Model& HilModel() {
  static const dynamics::Model m =
      dynamics::LoadModelFromUrdf(std::string(HYQ_SOURCE_DIR) + "/config/robots/hyq.urdf");
  return m;
}
inline hal::HalConfig HilHalConfig() {
  return config::LoadHalConfig(std::string(HYQ_SOURCE_DIR) + "/config/hyq_hal.yaml");
}

/// PD towards the standing posture on the process image (the rigs' stand-in controller).
inline void StandingPd(const dynamics::Model& model, hal::ProcessImage& image, double kp = 600,
                       double kd = 20) {
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const hal::JointInput& in = image.joints[static_cast<std::size_t>(j)];
    double tau = 0;
    if (std::isfinite(in.position_rad) && std::isfinite(in.velocity_rad_s))
      tau = kp * (model.q_standing(j) - in.position_rad) - kd * in.velocity_rad_s;
    image.commands[static_cast<std::size_t>(j)].torque_Nm = tau;
  }
}

/// The simulated robot held standing (these tests' master is a joint PD about the standing
/// posture; hyq-sim's default start is the resting crouch the daemon stands up from).
inline sim::SimulatedRobotConfig Standing() {
  sim::SimulatedRobotConfig rc;
  rc.start_height_m = 0.0;
  return rc;
}

/// HAL and SimulatedRobot in one thread over loopback buses. Master clock = simulated time.
struct LoopbackRig {
  explicit LoopbackRig(const sim::SimulatedRobotConfig& rc = Standing()) : cfg(HilHalConfig()) {
    std::vector<hal::CanChannel*> m, d;
    for (const hal::BusConfig& b : cfg.buses) {
      wires.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      m.push_back(&wires.back()->endpoint(0));
      d.push_back(&wires.back()->endpoint(1));
    }
    hal = std::make_unique<hal::Hal>(cfg, m);
    robot = std::make_unique<sim::SimulatedRobot>(HilModel(), cfg, d, rc);
    (void)robot->PollLockStep();  // boot-up messages
  }
  std::int64_t now() const { return kStartNs + robot->time_ns(); }
  /// One master cycle: Read, controller, Write, then the robot answers and steps.
  hal::HalStatus Cycle(const std::function<void(hal::ProcessImage&)>& controller = {}) {
    const hal::HalStatus r = hal->Read(now());
    if (controller) controller(hal->image());
    (void)hal->Write(now());
    steps_last = robot->PollLockStep();
    return r;
  }
  void BringUp(hal::DeviceState target = hal::DeviceState::kOp) {
    hal::RunBringUp(*hal, target, now(), [this] {
      (void)robot->PollLockStep();
      return now();
    });
    (void)robot->PollLockStep();
  }
  static constexpr std::int64_t kStartNs = 1'000'000'000;
  hal::HalConfig cfg;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<sim::SimulatedRobot> robot;
  int steps_last = 0;
};

/// A HAL master on UDP virtual buses udp::PORT0.. (one per bus), lock-step: after each SYNC it
/// waits (poll) until the TPDOs of every device it expects have arrived, then runs the next
/// cycle at once. Its clock is cycles x period (simulated time).
struct UdpMaster {
  explicit UdpMaster(const std::vector<std::string>& specs) : cfg(HilHalConfig()) {
    std::vector<hal::CanChannel*> m;
    for (const std::string& s : specs) {
      master.push_back(std::make_unique<hal::LockstepChannel>(drivers::OpenChannel(s)));
      m.push_back(master.back().get());
      channels.push_back(master.back().get());
      fds.push_back({master.back()->poll_fd(), POLLIN, 0});
    }
    hal = std::make_unique<hal::Hal>(cfg, m);
  }
  std::int64_t now() const { return 1'000'000'000 + cycles * 1'000'000; }
  /// Waits until the devices have announced themselves (any frame), at most timeout_ms.
  bool WaitForDevices(int timeout_ms) {
    const std::int64_t end = MonotonicNs() + std::int64_t{timeout_ms} * 1'000'000;
    while (MonotonicNs() < end) {
      std::size_t got = 0;
      for (auto& c : master) {
        (void)c->Pump();
        got += c->buffered();
      }
      if (got > 0) return true;
      (void)poll(fds.data(), fds.size(), 10);
    }
    return false;
  }
  /// Lock-step after a SYNC: waits for the TPDO of every device that owes one (2 s is a guard for
  /// a dropped frame, not a window a busy machine must meet); with none owed (early bring-up), at
  /// most 2 ms for NMT answers and heartbeats.
  bool AwaitAnswers(std::int64_t timeout_ns = 2'000'000'000) {
    return hal::WaitForLockstepInputs(*hal, channels, timeout_ns, 2'000'000);
  }
  hal::HalStatus Cycle(const std::function<void(hal::ProcessImage&)>& controller = {}) {
    const hal::HalStatus r = hal->Read(now());
    if (controller) controller(hal->image());
    (void)hal->Write(now());
    ++cycles;
    (void)AwaitAnswers();
    return r;
  }
  void BringUp() {
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now(), [this] {
      ++cycles;
      (void)AwaitAnswers();
      return now();
    });
    (void)AwaitAnswers(200'000'000);
  }
  hal::HalConfig cfg;
  std::vector<std::unique_ptr<hal::LockstepChannel>> master;
  std::vector<hal::LockstepChannel*> channels;  // the same, as the lock-step wait takes them
  std::vector<pollfd> fds;
  std::unique_ptr<hal::Hal> hal;
  std::int64_t cycles = 0;
};

}  // namespace hyq::testing
