#include "servo/runtime/servo_runner.h"

#include <poll.h>

#include <algorithm>
#include <cstdio>

#include "hal/clock.h"
#include "hal/config_error.h"
#include "hal/protocol.h"
#include "servo/runtime/realtime_thread.h"

namespace hyq::servo {

// --- lock-step ---------------------------------------------------------------------------------

namespace {

// the steps the simulated plant took without this loop so far (the newest any bus reported)
std::uint32_t PlantStalledSteps(std::span<LockstepChannel* const> channels) noexcept {
  std::uint32_t n = 0;
  for (const LockstepChannel* c : channels) n = std::max(n, c->plant_stalled_steps());
  return n;
}

}  // namespace

std::int64_t BringUp(hal::Hal& hal, const ServoConfig& config,
                     std::span<LockstepChannel* const> channels,
                     const std::function<bool()>& abort) {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t now = config.clock == ClockMode::kLockstep ? 0 : MonotonicNs();
  // in lock-step the HAL's timeout counts simulated time, and each cycle may wait up to 200 ms
  // for answers that never come: the wall time has its own bound (loop.lockstep_bringup_timeout_s),
  // and the message says which one ran out
  const std::int64_t wall0 = MonotonicNs();
  const auto timeout_ns = static_cast<std::int64_t>(config.lockstep_bringup_timeout_s * 1e9);
  hal::RunBringUp(hal, hal::DeviceState::kOp, now, [&] {
    if (abort && abort())
      throw hal::ConfigError("bring-up aborted by a stop request (SIGINT/SIGTERM) before every "
                             "device reached OP: " + hal.BringUpReport(now));
    if (config.clock == ClockMode::kLockstep && MonotonicNs() - wall0 > timeout_ns) {
      char head[160];
      std::snprintf(head, sizeof head,
                    "HAL bring-up to OP timed out after %g s of wall time "
                    "(loop.lockstep_bringup_timeout_s; lock-step: %lld cycles, %.3f s simulated): ",
                    config.lockstep_bringup_timeout_s, static_cast<long long>(now / period),
                    1e-9 * static_cast<double>(now));
      throw hal::ConfigError(head + hal.BringUpReport(now));
    }
    if (config.clock == ClockMode::kLockstep) {
      // devices that owe no TPDO yet answer NMT commands: give them a moment of wall time
      (void)hal::WaitForLockstepInputs(hal, channels, 200'000'000, 20'000'000);
      now += period;
    } else {
      now += period;
      SleepUntil(now);
    }
    return now;
  });
  return now;
}

void RunRealtime(ServoLoop& loop, const ServoConfig& config, std::int64_t start_ns) noexcept {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t next = start_ns;
  while (!loop.finished()) {
    next += period;
    SleepUntil(next);
    const std::int64_t woke = MonotonicNs();
    loop.Cycle(next, woke - next);
    const std::int64_t end = MonotonicNs();
    if (end > next + period) {  // overran the next wake-up: skip the periods already lost
      const std::int64_t lost = (end - next) / period;
      loop.CountSkipped(static_cast<std::uint64_t>(lost));
      next += lost * period;
    }
  }
}

void RunLockstep(ServoLoop& loop, const hal::Hal& hal, const ServoConfig& config,
                 std::span<LockstepChannel* const> channels, std::int64_t start_ns) noexcept {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t now = start_ns;
  // a device that stopped answering would make every cycle wait the full timeout: after a cycle
  // came up short, wait only briefly for the next thousand cycles
  int short_waits = 0;
  const auto long_ns = static_cast<std::int64_t>(config.lockstep_timeout_s * 1e9);
  const auto short_ns = static_cast<std::int64_t>(config.lockstep_short_timeout_s * 1e9);
  // a simulated plant that stepped on without this loop (a stall it injected) says so ahead of its
  // answers (hal::PlantClock): those periods are lost, as a stalled thread loses them in real
  // time; the clock jumps over them and the deadline monitor counts them
  std::uint32_t stalled_seen = PlantStalledSteps(channels);
  while (!loop.finished()) {
    now += period;
    loop.Cycle(now, 0);
    const bool complete = hal::WaitForLockstepInputs(hal, channels, short_waits > 0 ? short_ns : long_ns,
                                        std::min<std::int64_t>(short_ns, 1'000'000));
    if (!complete) short_waits = 1000;
    else if (short_waits > 0) --short_waits;
    const std::uint32_t stalled = PlantStalledSteps(channels);
    if (stalled > stalled_seen) {
      now += static_cast<std::int64_t>(stalled - stalled_seen) * period;
      loop.CountStall(stalled - stalled_seen);
      stalled_seen = stalled;
    }
  }
}

}  // namespace hyq::servo
