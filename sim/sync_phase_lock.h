// Real time: the simulated HyQ's physics steps phase-locked to the master's SYNC.
//
// The real boards sample their encoders at SYNC and act on a torque set-point when it arrives.
// hyq-sim steps its physics once per period on a timer of its own; left free, its phase to the
// daemon's SYNC is whatever the start-up gave, and a set-point that arrives just after the step
// it was meant for waits a whole further step: the loop's delay is then 1 or 2 ms by chance,
// run to run (docs/benchmarks.md: one extra millisecond is what rings a knee at a
// trot's touchdown, in lock-step with --delay-cycles 1 as in those real-time runs). Locked, a
// step begins `phase_ns` after each SYNC, when the set-point computed for it has arrived, as in
// lock-step (a step per SYNC, the newest set-point applied).
//
// A proportional phase lock on the step deadlines: the SYNC's arrival (as the bus thread saw
// it) gives the phase error of the next deadline, wrapped into half a period either way; the
// deadline moves by a quarter of the error, at most max_slew_ns per step, so one late SYNC
// (a stalled master) shifts it a little and a steady offset is gone in a few tens of steps.
// With no SYNC for max_sync_age_ns (no master, or a dead one) the steps run free.
#pragma once

#include <algorithm>
#include <cstdint>

namespace hyq::sim {

struct SyncPhaseLock {
  std::int64_t period_ns = 1'000'000;
  std::int64_t phase_ns = 500'000;      // a step begins this long after the SYNC; < 0: off
  std::int64_t max_slew_ns = 50'000;    // the largest move of a deadline per step
  std::int64_t max_sync_age_ns = 20'000'000;

  bool enabled() const noexcept { return phase_ns >= 0; }
  /// Locking now: on, a SYNC seen (last_sync_ns > 0) and not older than max_sync_age_ns.
  bool Active(std::int64_t last_sync_ns, std::int64_t now_ns) const noexcept {
    return enabled() && last_sync_ns > 0 && now_ns - last_sync_ns <= max_sync_age_ns;
  }

  /// The phase error of the deadline due_ns: due − (last SYNC + phase), wrapped into
  /// [−period/2, period/2). Positive: the step is due later than the lock wants.
  std::int64_t Error(std::int64_t due_ns, std::int64_t last_sync_ns) const noexcept {
    const std::int64_t d = (due_ns - last_sync_ns - phase_ns) % period_ns;  // (−period, period)
    const std::int64_t m = d < 0 ? d + period_ns : d;                       // [0, period)
    return m >= period_ns / 2 ? m - period_ns : m;
  }

  /// What to add to the deadline due_ns (at time now_ns) to bring it towards the lock; 0 when
  /// not Active.
  std::int64_t Correction(std::int64_t due_ns, std::int64_t last_sync_ns,
                          std::int64_t now_ns) const noexcept {
    if (!Active(last_sync_ns, now_ns)) return 0;
    return std::clamp(-Error(due_ns, last_sync_ns) / 4, -max_slew_ns, max_slew_ns);
  }
};

}  // namespace hyq::sim
