// The HAL master and the device emulator talking over four UDP-multicast virtual CAN buses in
// one process (the emulator polls in its own thread), for the HAL-over-drivers test and the
// SYNC → inputs round-trip benchmark. Run inside a private network namespace (in_netns.sh).
#pragma once

#include <poll.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "hal/clock.h"
#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/lockstep_channel.h"
#include "hal/protocol.h"

namespace hyq::testing {

/// Pumps the master channels until together they hold `expected` TPDOs for the last SYNC (true),
/// or until `timeout_ns` of wall time has passed (false). Between rounds it polls `fds`: with
/// `spin`, without sleeping (the lowest latency, for the round-trip benchmark), else for up to
/// the time left.
inline bool WaitForTpdos(std::vector<std::unique_ptr<hal::LockstepChannel>>& master,
                         std::vector<pollfd>& fds, int expected, std::int64_t timeout_ns,
                         bool spin) {
  const std::int64_t end = MonotonicNs() + timeout_ns;
  for (;;) {
    int got = 0;
    for (auto& m : master) got += m->Pump();
    if (got >= expected) return true;
    const std::int64_t left = end - MonotonicNs();
    if (left <= 0) return false;
    const int poll_ms = spin ? 0 : static_cast<int>(std::max<std::int64_t>(1, left / 1'000'000));
    (void)poll(fds.data(), fds.size(), poll_ms);
  }
}

struct VirtualRig {
  explicit VirtualRig(int first_port) : cfg(config::LoadHalConfig(HYQ_HAL_CONFIG)) {
    // the rig's master runs on a test thread that a loaded machine may stall for more than the
    // boards' 8 ms set-point timer; the rig tests the buses (the timer has its own tests)
    cfg.timing.device_setpoint_timeout_s = 1.0;
    std::vector<hal::CanChannel*> masters, devices;
    for (std::size_t b = 0; b < cfg.buses.size(); ++b) {
      const std::string spec = "udp::" + std::to_string(first_port + static_cast<int>(b));
      master.push_back(std::make_unique<hal::LockstepChannel>(drivers::OpenChannel(spec)));
      device.push_back(drivers::OpenChannel(spec));
      masters.push_back(master.back().get());
      devices.push_back(device.back().get());
      device_fds.push_back({device.back()->poll_fd(), POLLIN, 0});
      master_fds.push_back({master.back()->poll_fd(), POLLIN, 0});
    }
    hal = std::make_unique<hal::Hal>(cfg, masters);
    emulator = std::make_unique<hal::Emulator>(cfg, devices);
    thread = std::thread([this] {
      while (!stop) {
        (void)poll(device_fds.data(), device_fds.size(), 1);
        emulator->Poll(MonotonicNs());
      }
    });
  }
  ~VirtualRig() {
    stop = true;
    thread.join();
  }
  /// Brings every device to OP (throws with the HAL's report if one does not come up). Each
  /// cycle waits (up to 5 ms) for the devices that answer SYNC to answer before the next Read,
  /// so a loaded machine slows the bring-up down instead of failing it.
  void BringUp() {
    std::int64_t now = MonotonicNs();
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now, [&] {
      (void)WaitForInputs(13, 5'000'000);
      const std::int64_t next = now + 1'000'000;  // 1 kHz when the machine keeps up
      timespec t{next / 1'000'000'000, next % 1'000'000'000};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
      now = MonotonicNs();
      return now;
    });
    // bring-up ends with a Write: take that cycle's inputs so the next Write starts clean
    (void)WaitForInputs(13, 20'000'000);
    (void)hal->Read(MonotonicNs());
  }
  /// Waits (poll) until every master channel holds its bus's TPDOs for the last SYNC, at most
  /// timeout_ns; returns whether they all arrived.
  bool WaitForInputs(int expected, std::int64_t timeout_ns) {
    return WaitForTpdos(master, master_fds, expected, timeout_ns, /*spin=*/true);
  }

  hal::HalConfig cfg;
  std::vector<std::unique_ptr<hal::LockstepChannel>> master;
  std::vector<std::unique_ptr<hal::CanChannel>> device;
  std::vector<pollfd> device_fds, master_fds;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<hal::Emulator> emulator;
  std::atomic<bool> stop{false};
  std::thread thread;
};

}  // namespace hyq::testing
