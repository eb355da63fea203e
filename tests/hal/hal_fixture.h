// The HAL and the device emulator talking over four in-process loopback buses (one per leg), on
// a simulated clock: one Step() is one 1 ms cycle (Read, controller, Write, devices answer).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"

namespace hyq::hal::testing {

inline constexpr std::int64_t kPeriodNs = 1'000'000;

struct HalRig {
  /// Each bus is a LoopbackBus of `endpoints` (0: the HAL, 1: the devices, more for tests that
  /// put frames of their own on the wire), each with a receive queue of `queue_depth` frames.
  explicit HalRig(HalConfig cfg = DefaultHalConfig(), std::uint64_t seed = 1,
                  std::size_t endpoints = 2, std::size_t queue_depth = 256)
      : config(cfg) {
    for (const BusConfig& b : config.buses) {
      wires.push_back(std::make_unique<LoopbackBus>(b.name, endpoints, queue_depth, true));
      hal_side.push_back(&wires.back()->endpoint(0));
      device_side.push_back(&wires.back()->endpoint(1));
    }
    hal = std::make_unique<Hal>(config, hal_side);
    emu = std::make_unique<Emulator>(config, device_side, seed);
  }

  // one cycle: inputs, the controller hook, outputs, the devices answer, time advances
  HalStatus Step(const std::function<void(ProcessImage&)>& controller = {}) {
    HalStatus read = hal->Read(now_ns);
    if (controller) controller(hal->image());
    HalStatus write = hal->Write(now_ns);
    emu->Poll(now_ns);
    now_ns += kPeriodNs;
    for (auto& w : wires) w->set_time_ns(now_ns);
    return static_cast<std::uint8_t>(read) >= static_cast<std::uint8_t>(write) ? read : write;
  }
  void Steps(int n) {
    for (int i = 0; i < n; ++i) (void)Step();
  }

  void BringUp(DeviceState target = DeviceState::kOp) {
    emu->Poll(now_ns);  // power-on boot-up messages
    RunBringUp(*hal, target, now_ns, [this] {
      emu->Poll(now_ns);
      now_ns += kPeriodNs;
      return now_ns;
    });
    // RunBringUp returns right after a Write: let the devices answer that SYNC
    emu->Poll(now_ns);
    now_ns += kPeriodNs;
  }

  const DeviceRuntime& Device(int bus, int index) const {
    return hal->bus(static_cast<std::size_t>(bus)).devices()[static_cast<std::size_t>(index)];
  }

  HalConfig config;
  std::vector<std::unique_ptr<LoopbackBus>> wires;
  std::vector<CanChannel*> hal_side, device_side;
  std::unique_ptr<Hal> hal;
  std::unique_ptr<Emulator> emu;
  std::int64_t now_ns = 1'000'000'000;
};

}  // namespace hyq::hal::testing
