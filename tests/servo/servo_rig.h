// The servo loop, the HAL and the device emulator over four in-process loopback buses on a
// simulated clock (no physics): the boards report the standing posture at rest and the IMU reads
// gravity. One Step() is one period: ServoLoop::Cycle (read .. write), then the devices answer.
#pragma once

#include <deque>
#include <memory>
#include <vector>

#include "config/servo_config_loader.h"
#include "dynamics/urdf_loader.h"
#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"
#include "servo/runtime/servo_loop.h"
#include "tests/support/paths.h"

namespace hyq::testing {

/// Records what the loop sends; hands out queued commands.
class RecordingSink : public servo::TelemetrySink {
 public:
  RecordingSink() { events.reserve(1024); }
  bool Push(const servo::TelemetrySnapshot& s) noexcept override {
    last = s;
    ++snapshots;
    return true;
  }
  bool PushEvent(const servo::SafetyEvent& e) noexcept override {
    if (events.size() < events.capacity()) events.push_back(e);
    return true;
  }
  bool PopCommand(servo::ServoCommand* c) noexcept override {
    if (commands.empty()) return false;
    *c = commands.front();
    commands.pop_front();
    return true;
  }
  bool HasEvent(servo::EventReason r) const {
    for (const auto& e : events)
      if (e.reason == r) return true;
    return false;
  }
  servo::TelemetrySnapshot last;
  std::uint64_t snapshots = 0;
  std::vector<servo::SafetyEvent> events;
  std::deque<servo::ServoCommand> commands;
};

inline servo::ServoConfig DefaultServoConfig() {
  return config::LoadServoConfig(SourceDir() / "config/hyq_servo.yaml");
}

struct ServoRig {
  static constexpr std::int64_t kPeriodNs = 1'000'000;

  explicit ServoRig(servo::ServoConfig cfg = DefaultServoConfig())
      : config(std::move(cfg)),
        model(dynamics::LoadModelFromUrdf(config.urdf)) {
    for (const hal::BusConfig& b : config.hal.buses) {
      wires.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      hal_side.push_back(&wires.back()->endpoint(0));
      device_side.push_back(&wires.back()->endpoint(1));
    }
    hal = std::make_unique<hal::Hal>(config.hal, hal_side);
    emu = std::make_unique<hal::Emulator>(config.hal, device_side, 1);
    loop = std::make_unique<servo::ServoLoop>(config, model, *hal, &sink);
    SetStanding();
  }

  /// The boards report the standing posture at rest, the IMU gravity (mounted upside down).
  void SetStanding() {
    for (int j = 0; j < 12; ++j) emu->SetJointState(j, model.q_standing(j), 0.0, 0.0);
    const Eigen::Vector3d f_I = model.imu.R_BF.transpose() * Eigen::Vector3d(0, 0, 9.81);
    emu->SetImu({0.0, 0.0, 0.0}, {f_I.x(), f_I.y(), f_I.z()});
  }

  void BringUpAndStart() {
    emu->Poll(now_ns);
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now_ns, [this] {
      emu->Poll(now_ns);
      now_ns += kPeriodNs;
      return now_ns;
    });
    emu->Poll(now_ns);
    now_ns += kPeriodNs;
    loop->Start(now_ns);
  }

  void Step() {
    loop->Cycle(now_ns, 0);
    emu->Poll(now_ns);
    now_ns += kPeriodNs;
    for (auto& w : wires) w->set_time_ns(now_ns);
  }
  void Steps(int n) {
    for (int i = 0; i < n; ++i) Step();
  }

  servo::ServoConfig config;
  dynamics::Model model;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires;
  std::vector<hal::CanChannel*> hal_side, device_side;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<hal::Emulator> emu;
  RecordingSink sink;
  std::unique_ptr<servo::ServoLoop> loop;
  std::int64_t now_ns = 1'000'000'000;
};

}  // namespace hyq::testing
