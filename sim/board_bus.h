// Real time: HyQ's boards answering SYNCs from a thread of their own (the bus thread), as the
// real boards answer whatever the physics computer does. While it runs, the emulator (board
// state, set-points, sensor values, injected faults) is the bus thread's alone: the stepping
// thread hands it each step's sensor values and takes the boards' set-points back through two
// wait-free rings (the newest wins), so neither thread ever waits for the other, whichever of
// them a stall catches. A late or stalled physics step therefore never leaves a SYNC unanswered:
// the answer carries the last step's state, counted in stale_answers().
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <thread>

#include "hal/latency_histogram.h"
#include "hal/spsc_ring.h"
#include "sim/simulated_robot.h"

namespace hyq::sim {

/// `setup` runs first on the bus thread (its scheduling: hyq-sim puts it SCHED_FIFO on the
/// servo's core). enabled = false: the stepping thread answers between its steps (a stalled step
/// then leaves the SYNCs unanswered).
struct BusThreadConfig {
  bool enabled = true;
  std::function<void()> setup;
};

class BoardBus {
 public:
  static constexpr std::size_t kHandoffDepth = 8;

  /// Configuration time: the rings (allocated here). `robot` is not owned.
  explicit BoardBus(SimulatedRobot* robot);
  ~BoardBus();
  BoardBus(const BoardBus&) = delete;
  BoardBus& operator=(const BoardBus&) = delete;

  /// Hands the robot's boards to a new bus thread, which runs `setup` first.
  void Start(const std::function<void()>& setup);
  /// Stops and joins the thread; the boards go back to the stepping thread.
  void Stop() noexcept;

  // the stepping thread's side
  /// The newest set-points the boards handed over since the last call (*f unchanged if none).
  void TakeNewestSetpoints(SetpointFrame* f) noexcept;
  /// A step's sensor values for the boards (dropped if the bus thread is stalled: it takes the
  /// next step's).
  void GiveSensors(const SensorFrame& f) noexcept { (void)sensor_frames_.TryPush(f); }
  /// When the next physics step is due (monotonic ns), for the stale-answer count.
  void SetStepDue(std::int64_t ns) noexcept { step_due_ns_.store(ns, std::memory_order_relaxed); }

  /// SYNCs answered while the physics step that was due was more than a period late (the
  /// latest state held).
  std::uint64_t stale_answers() const noexcept { return stale_answers_; }
  /// The time between the bus thread's wake-ups (a gap over a period: it was not scheduled).
  const hal::LatencyHistogram& gap() const noexcept { return gap_; }
  /// Its work per wake-up.
  const hal::LatencyHistogram& poll_time() const noexcept { return poll_time_; }

 private:
  void Run(const std::function<void()>& setup) noexcept;

  SimulatedRobot& robot_;
  hal::SpscRing<SensorFrame> sensor_frames_{kHandoffDepth};      // stepping → bus thread
  hal::SpscRing<SetpointFrame> setpoint_frames_{kHandoffDepth};  // bus thread → stepping
  std::atomic<std::int64_t> step_due_ns_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::uint64_t stale_answers_ = 0;
  hal::LatencyHistogram gap_, poll_time_;
};

}  // namespace hyq::sim
