// The servo thread's own deadline (docs/servo.md, "Timing"): each cycle's work, read start to
// write end, must fit in budget_fraction × period; max_consecutive_misses misses in a row are a
// fault (reason kDeadlineMiss). In real time the work is wall time plus the wake-up latency; in
// lock-step it is the thread's CPU time, so that a preemption by another process (wall time the
// servo did not use) is not a miss. In lock-step the plant waits for the answer, so a late cycle
// cannot hurt it: there the misses are counted and reported, and stop the daemon only with
// stop_in_lockstep (on a VM the thread's CPU time includes what the host stole from the vCPU:
// seen on the CI machine, 8 cycles in a row of 1-14 ms while a JVM started beside the run).
// A stall the plant reports in lock-step (AddStall: the simulated plant stepped on without this
// loop, hal::PlantClock) is different: there the plant did not wait, as in real time, so its lost
// periods are misses in a row and a fault at the limit whatever stop_in_lockstep says.
#pragma once

#include <cstdint>

#include "hal/config_key.h"
#include "servo/runtime/fault.h"

namespace hyq::servo {

struct DeadlineConfig {
  double budget_fraction = 0.9;   // cycle work (read .. write) must end within this × period
  int max_consecutive_misses = 5; // this many misses in a row → DAMPING (reason kDeadlineMiss)
  bool stop_in_lockstep = false;  // ... under the lock-step clock too (otherwise only counted)

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("budget_fraction", &budget_fraction).In(0.05, 1.0)
                 .Doc("wake-up latency + cycle work (read .. write) within this × the period"));
    a->Visit(hal::Key("max_consecutive_misses", &max_consecutive_misses).In(1, 1000)
                 .Doc("this many misses in a row → DAMPING (reason deadline_miss)"));
    a->Visit(hal::Key("stop_in_lockstep", &stop_in_lockstep)
                 .Doc("... under the lock-step clock too (otherwise only counted)"));
  }
};

class DeadlineMonitor {
 public:
  /// `enforce` false: misses are counted, never a fault (lock-step without stop_in_lockstep).
  DeadlineMonitor(const DeadlineConfig& config, double period_s, bool enforce = true);

  /// One cycle's work `used_ns` (and its wall time `total_ns`, for the fault's detail); a fault
  /// once the misses in a row reach the limit (and every cycle after, until one fits), if enforced.
  /// Periods lost to a stall since the last call (AddStall) count first, each a miss in a row
  /// before this cycle, and reaching the limit with them is a fault even when not enforced.
  Fault Observe(std::int64_t used_ns, std::int64_t total_ns) noexcept;
  /// Lock-step: the plant ran `periods` periods without this loop (a stall), for the next Observe.
  void AddStall(std::uint32_t periods) noexcept { stalled_ += periods; }

  std::int64_t budget_ns() const noexcept { return budget_ns_; }
  std::uint64_t misses() const noexcept { return misses_; }
  std::uint32_t consecutive() const noexcept { return consecutive_; }
  std::uint32_t max_consecutive() const noexcept { return max_consecutive_; }

 private:
  std::int64_t budget_ns_;
  std::uint32_t limit_;
  bool enforce_;
  std::uint64_t misses_ = 0;
  std::uint32_t consecutive_ = 0, max_consecutive_ = 0;
  std::uint32_t stalled_ = 0;  // periods lost to a stall, not yet observed
};

}  // namespace hyq::servo
