// The clocks that drive a ServoLoop (docs/servo.md, "Timing") and the bring-up that precedes it.
// The servo thread's real-time set-up is servo/runtime/realtime_thread.h.
//
//  - real time: the period on absolute CLOCK_MONOTONIC time (clock_nanosleep TIMER_ABSTIME);
//    wake-up latency = actual − scheduled wake-up; a cycle that ends after the next wake-up
//    was due skips the periods it overran (counted) instead of running them back to back.
//  - lock-step: virtual time (cycle × period). After each cycle's SYNC the runner waits until
//    every device that owes an answer has answered (or a wall-clock timeout passes) and runs the
//    next cycle at once: with a simulator that steps once per SYNC the closed loop is
//    deterministic and runs as fast as both sides compute. A simulator that stepped on without
//    the loop (an injected stall; hal::PlantClock) moves the virtual time over those periods, and
//    the loop counts them as skipped and as deadline misses (ServoLoop::CountStall).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hal/can_channel.h"
#include "hal/hal.h"
#include "hal/lockstep_channel.h"
#include "servo/runtime/servo_config.h"
#include "servo/runtime/servo_loop.h"

namespace hyq::servo {

using hal::LockstepChannel;

/// Brings every device to OP with the configured clock (throws hal::ConfigError with the HAL's
/// report on timeout); returns the time of the last bring-up cycle. `channels` is empty in real
/// time. `abort` (may be empty) is asked every cycle: true ends the bring-up at once with a
/// hal::ConfigError saying so (an operator's SIGTERM must not wait for the bring-up timeout).
std::int64_t BringUp(hal::Hal& hal, const ServoConfig& config,
                     std::span<LockstepChannel* const> channels,
                     const std::function<bool()>& abort = {});

/// Runs the loop until loop.finished(). Real time: from `start_ns`; lock-step: virtual time from
/// `start_ns`, waiting on `channels`.
void RunRealtime(ServoLoop& loop, const ServoConfig& config, std::int64_t start_ns) noexcept;
void RunLockstep(ServoLoop& loop, const hal::Hal& hal, const ServoConfig& config,
                 std::span<LockstepChannel* const> channels, std::int64_t start_ns) noexcept;

}  // namespace hyq::servo
