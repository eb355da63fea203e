// When a solve must stop, on the wall clock or on the solving thread's CPU clock.
//
// Real time (the daemon at 1 kHz on its clock): the plant does not wait, so the budget is wall
// time. Lock-step (hardware-in-the-loop against hyq-sim): the plant waits for the servo, and time
// the thread spent preempted costs the robot nothing; the budget is then the thread's CPU time,
// as the servo loop's deadline monitor counts it there (servo/runtime/deadline_monitor.h).
//
// Reading the thread's CPU clock is a system call (0.2-1.5 us measured on the 2-core VMs, against
// ~20 ns for the wall clock, and a solve checks its deadline once per iteration). A thread's CPU
// time never runs ahead of the wall time, so a CPU-time deadline keeps a wall-clock bound before
// which it cannot have passed, reads the CPU clock only once that bound is reached, and then moves
// the bound on by what is left: an unpreempted solve reads it once at most.
#pragma once

#include <chrono>
#include <cstdint>

namespace hyq::qp {

enum class DeadlineClock : std::uint8_t {
  kMonotonic,  ///< wall time, CLOCK_MONOTONIC (= std::chrono::steady_clock)
  kThreadCpu,  ///< the calling thread's CPU time, CLOCK_THREAD_CPUTIME_ID
};

class Deadline {
 public:
  Deadline() = default;  // now on the wall clock: already passed
  /// `budget` from now on `clock` (kThreadCpu: the calling thread's, which must be the one that
  /// checks it).
  static Deadline In(std::chrono::nanoseconds budget,
                     DeadlineClock clock = DeadlineClock::kMonotonic) noexcept;
  /// An absolute steady-clock time.
  static Deadline At(std::chrono::steady_clock::time_point t) noexcept;

  bool Passed() const noexcept;
  /// What is left, at least (on kThreadCpu the wall-clock bound while it lasts: no system call).
  std::chrono::nanoseconds Remaining() const noexcept;
  /// A deadline on the same clock that leaves (1 − share) of Remaining() for afterwards.
  Deadline Share(double share) const noexcept;
  DeadlineClock clock() const noexcept { return clock_; }

 private:
  DeadlineClock clock_ = DeadlineClock::kMonotonic;
  std::int64_t cpu_at_ns_ = 0;  // kThreadCpu: the deadline on the thread's CPU clock
  // the wall time before which the deadline has not passed (kMonotonic: the deadline itself);
  // a cache that Passed() and Remaining() move on, hence mutable
  mutable std::int64_t wall_at_ns_ = 0;
};

}  // namespace hyq::qp
