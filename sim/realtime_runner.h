// Real time: the simulated HyQ's physics on absolute CLOCK_MONOTONIC deadlines (timerfd,
// TFD_TIMER_ABSTIME) every period, each step kept at SimulatedRobotConfig::sync_phase_ns after
// the master's SYNC (SyncPhaseLock, sim/sync_phase_lock.h). SYNCs are answered as they arrive
// with the latest state, by the boards' own thread (sim/board_bus.h) or, without it, by the
// stepping thread between steps, also after each step of a catch-up (at most kMaxCatchUp at
// once). Each step's lateness (start − due) goes into step_lateness(), its duration into
// step_time().
#pragma once

#include <atomic>
#include <cstdint>

#include "hal/latency_histogram.h"
#include "sim/board_bus.h"
#include "sim/simulated_robot.h"

namespace hyq::sim {

struct RealtimeCounters {
  std::uint64_t overruns = 0;       // timer periods that passed unanswered
  std::uint64_t late_steps = 0;     // steps begun more than a period after due
  std::uint64_t dropped_steps = 0;  // periods given up (more than kMaxCatchUp late)
};

class RealtimeRunner {
 public:
  static constexpr std::uint64_t kMaxCatchUp = 10;  // steps taken at once when late

  /// `robot` is not owned and must outlive this.
  explicit RealtimeRunner(SimulatedRobot* robot);

  /// Runs until `stop` or `duration_s` of simulated time (0: until stop). Returns the steps
  /// taken. Throws std::runtime_error when the timer cannot be set up.
  std::uint64_t Run(const std::atomic<bool>& stop, double duration_s,
                    const BusThreadConfig& bus = {});

  const RealtimeCounters& counters() const noexcept { return counters_; }
  const hal::LatencyHistogram& step_lateness() const noexcept { return step_lateness_; }
  const hal::LatencyHistogram& step_time() const noexcept { return step_time_; }
  /// SYNC-locked: |phase error| of each step's start, i.e. how far from sync_phase_ns after the
  /// last SYNC it began (steps while a master sends SYNCs)
  const hal::LatencyHistogram& sync_phase_error() const noexcept { return sync_phase_error_; }
  /// The boards' thread (its histograms and stale answers).
  const BoardBus& bus() const noexcept { return bus_; }

 private:
  SimulatedRobot& robot_;
  BoardBus bus_;
  RealtimeCounters counters_;
  hal::LatencyHistogram step_lateness_, step_time_, sync_phase_error_;
};

}  // namespace hyq::sim
