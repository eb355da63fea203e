// The servo cycle (docs/servo.md), one line per stage, as mj_step reads:
//   read → commands → input checks → estimate → reference → control → safety decision → write
//   → telemetry
// The checks only find faults (input_checker.h, output_checker.h, deadline_monitor.h); every
// decision about the mode and the outputs is the safety state machine's
// (safety_state_machine.h); the commands' mode rules are servo/command/command_rules.h, acting
// through command_port.h; the reference stage samples the motion phases (stand-up, reference,
// sit-down: servo/reference/motion_sequencer.h), whose requests the loop relays to the safety
// state machine. One call of Cycle() per period, from one thread; nothing in it allocates, locks,
// logs, blocks or throws. The clock (real time or lock-step) is the caller's:
// servo/runtime/servo_runner.h.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>

#include "dynamics/cycle_dynamics.h"
#include "hal/hal.h"
#include "hal/latency_histogram.h"
#include "hal/lockstep_channel.h"
#include "servo/common/servo_types.h"
#include "servo/control/controller.h"
#include "servo/estimation/disturbance_observer.h"
#include "servo/estimation/estimator.h"
#include "servo/estimation/friction_estimator.h"
#include "servo/reference/motion_sequencer.h"
#include "servo/reference/reference.h"
#include "servo/runtime/command_port.h"
#include "servo/runtime/control_pipeline.h"
#include "servo/runtime/deadline_monitor.h"
#include "servo/runtime/input_checker.h"
#include "servo/runtime/safety_state_machine.h"
#include "servo/runtime/servo_config.h"
#include "servo/runtime/stop_class.h"
#include "servo/telemetry/telemetry_snapshot.h"

namespace hyq::servo {

/// Counters and distributions of a run (for the summary and the benchmark).
struct LoopStats {
  std::uint64_t cycles = 0;
  std::uint64_t active_cycles = 0;
  std::uint64_t deadline_misses = 0;
  std::uint32_t consecutive_misses = 0, max_consecutive_misses = 0;
  std::uint64_t skipped_cycles = 0;           // kept by the runner
  std::uint64_t answer_wait_timeouts = 0;     // real time: reads whose answer wait ran out
  std::uint64_t telemetry_drops = 0, event_drops = 0;
  std::uint64_t commands_applied = 0, commands_rejected = 0;
  std::uint64_t controller_fallbacks = 0;
  /// of those, the ones whose QP ran out of its time budget (controller time_budget_us; wall
  /// time, or the thread's CPU time under the lock-step clock) rather than its iterations
  std::uint64_t controller_fallbacks_deadline = 0;
  /// of those, the ones whose QP ran under half or over 1.25× its budget: the thread was stalled
  /// (DeadlineSpentByAStall, servo/control/id_types.h), not the QP slow
  std::uint64_t controller_fallbacks_deadline_stalled = 0;
  hal::LatencyHistogram wakeup;               // wake-up latency
  hal::LatencyHistogram cycle;                // read start .. write end
  hal::LatencyHistogram control;              // dynamics + controller
  double tracking_error_sum_rad = 0.0;        // Σ ‖q_ref − q‖ over ACTIVE cycles
  double tracking_error_max_rad = 0.0;
  double joint_speed_max_rad_s = 0.0;         // the largest measured |q̇| over ACTIVE cycles ...
  int joint_speed_max_joint = -1;             // ... on this joint (-1: none yet)
  double joint_speed_max_at_s = 0.0;          // ... this long after the first ACTIVE cycle
  double qp_time_sum_us = 0.0, qp_time_max_us = 0.0;  // Stage I + II, ACTIVE cycles
};

class ServoLoop {
 public:
  static constexpr std::size_t kFirstEvents = 32;

  /// Configuration time: builds the estimator, the reference, every controller (QP workspaces)
  /// and the dynamics workspace. `hal` and `sink` (may be null) are not owned.
  ServoLoop(const ServoConfig& config, const dynamics::Model& model, hal::Hal& hal,
            TelemetrySink* sink);
  ~ServoLoop();
  ServoLoop(const ServoLoop&) = delete;
  ServoLoop& operator=(const ServoLoop&) = delete;

  /// After the bring-up (every device in OP): INIT → STANDBY.
  void Start(std::int64_t now_ns) noexcept;

  /// One cycle at `now_ns` (monotonic or virtual); `wakeup_latency_ns` is for the record.
  void Cycle(std::int64_t now_ns, std::int64_t wakeup_latency_ns) noexcept;

  /// Real time: before each cycle's read, wait at most config.answer_wait_s after the cycle
  /// began (never past period − answer_wait_s after `now_ns`) for the answers still owed on
  /// `channels` (one per bus, the HAL's order; not owned). Empty (the default): the read takes
  /// what has arrived.
  void SetAnswerWait(std::span<hal::LockstepChannel* const> channels) noexcept {
    answer_channels_ = channels;
    answer_wait_ns_ = static_cast<std::int64_t>(config_.answer_wait_s() * 1e9);
    period_ns_ = static_cast<std::int64_t>(1e9 / config_.rate_hz());
  }

  /// A controlled stop (from any thread, e.g. a signal handler's thread): damping if ACTIVE,
  /// then zero torque and the devices back to PRE-OP.
  void RequestStop() noexcept { stop_requested_.store(true, std::memory_order_relaxed); }
  /// STOPPED and the devices in PRE-OP (or the stop timeout passed): the runner may return.
  bool finished() const noexcept { return finished_; }

  ServoMode mode() const noexcept { return safety_.mode(); }
  /// The mode and cycle count for other threads (progress lines, supervisors).
  ServoMode published_mode() const noexcept { return published_mode_.load(std::memory_order_relaxed); }
  std::uint64_t published_cycles() const noexcept { return published_cycles_.load(std::memory_order_relaxed); }
  /// Seconds spent in ACTIVE so far, for other threads.
  double published_active_s() const noexcept { return published_active_s_.load(std::memory_order_relaxed); }
  const LoopStats& stats() const noexcept { return stats_; }
  const TelemetrySnapshot& snapshot() const noexcept { return snap_; }
  const Controller& controller() const noexcept { return pipeline_->controller(); }
  const StateEstimator& estimator() const noexcept { return estimator_; }
  const FrictionEstimator& friction() const noexcept { return pipeline_->friction(); }
  const DisturbanceObserver& disturbance() const noexcept { return pipeline_->disturbance(); }
  std::uint64_t events() const noexcept { return safety_.events(); }
  /// The run's first events (up to kFirstEvents) and last event, for the summary.
  std::span<const SafetyEvent> first_events() const noexcept {
    return {first_events_.data(), num_first_events_};
  }
  const SafetyEvent& last_event() const noexcept { return last_event_; }
  /// Events of the run by reason (index: EventReason).
  const std::array<std::uint32_t, kNumEventReasons>& events_by_reason() const noexcept {
    return by_reason_;
  }

  /// The runner skipped `n` periods to get back on schedule.
  void CountSkipped(std::uint64_t n) noexcept { stats_.skipped_cycles += n; }
  /// Lock-step: the plant ran `n` periods without this loop (a stall the simulator injected,
  /// hal::PlantClock): skipped periods, and misses in a row at the next cycle's deadline check,
  /// a deadline_miss fault at the limit even without deadline.stop_in_lockstep.
  void CountStall(std::uint32_t n) noexcept {
    CountSkipped(n);
    deadline_.AddStall(n);
  }

  /// Fault injection: the next `cycles` cycles each take `extra_ns` longer (busy wait).
  void InjectOverrun(std::int64_t extra_ns, int cycles) noexcept {
    overrun_ns_.store(extra_ns, std::memory_order_relaxed);
    overrun_cycles_.store(cycles, std::memory_order_relaxed);
  }

 private:
  // the stages of Cycle(), in order
  void BeginCycle(std::int64_t now_ns) noexcept;
  void TakeCommands(std::int64_t now_ns) noexcept;
  void CheckInputs(hal::HalStatus read_status) noexcept;
  void Fail(const Fault& f) noexcept;
  // the lost joints' boards out of OP during a stop (their valves closed); where lost_ grows
  void ReleaseLostJoints() noexcept;
  void SampleReference() noexcept;
  void RunController() noexcept;
  void ApplyDecision(const SafetyDecision& d, std::int64_t now_ns) noexcept;
  void SpinInjectedOverrun() noexcept;
  void EndCycle(const SafetyDecision& d, std::int64_t wakeup_latency_ns,
                std::int64_t cpu_ns) noexcept;
  void PublishTelemetry(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws,
                        ServoMode mode) noexcept;

  void EstimateFriction() noexcept;
  // the motion phases (motion_sequencer.h): what the sequencer is told, what it asks for
  MotionInputs MotionNow() const noexcept;
  void Relay(const MotionRequests& r) noexcept;
  void EnterActive() noexcept;
  VectorJ MeasuredTorque() const noexcept;
  void ObserveFeet() noexcept;
  void Damping() noexcept;
  void FillSnapshot(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws) noexcept;
  void DrainEvents() noexcept;

  ServoConfig config_;
  const dynamics::Model& model_;
  hal::Hal& hal_;
  std::span<hal::LockstepChannel* const> answer_channels_;
  std::int64_t answer_wait_ns_ = 0, period_ns_ = 0;  // set with answer_channels_
  TelemetrySink* sink_;
  double dt_;

  InputChecker checker_;
  SafetyStateMachine safety_;
  DeadlineMonitor deadline_;
  StateEstimator estimator_;
  std::unique_ptr<Reference> reference_;
  // friction estimate → disturbance observer → controller, shared with the simulated experiment;
  // its environment() is what the controller gets: env_, or the estimated μ below it
  std::unique_ptr<ControlPipeline> pipeline_;
  std::unique_ptr<dynamics::CycleDynamics> dyn_;
  ContactEnvironment env_;     // configured or commanded μ (the estimate's upper bound)
  FeedbackGains base_gains_;
  CommandPort command_port_;  // what a command may change (built once)
  ReferenceSample ref_;
  JointReference joint_ref_;  // the phase's: the enable ramp, the stand-up or the sit-down
  FootContacts contacts_;     // the estimator's, for the reference's contact-aware phases
  bool feet_known_ = false;
  LostInputs lost_;           // what a fault's stop must do without (stop_class.h)   // this settling cycle's feet observer ran (ObserveFeet)
  MotionSequencer sequencer_;  // writes ref_ and joint_ref_
  IdOutput out_;
  IdStatus id_status_ = IdStatus::kOk;
  dynamics::VectorJ tau_ = dynamics::VectorJ::Zero();
  double active_time_ = 0.0;
  EstimatorStatus est_status_ = EstimatorStatus::kNoImu;
  bool finished_ = false;
  std::uint64_t cycle_ = 0;
  std::atomic<bool> stop_requested_{false};
  std::atomic<ServoMode> published_mode_{ServoMode::kInit};
  std::atomic<std::uint64_t> published_cycles_{0};
  std::atomic<double> published_active_s_{0.0};
  std::atomic<std::int64_t> overrun_ns_{0};
  std::atomic<int> overrun_cycles_{0};
  LoopStats stats_;
  TelemetrySnapshot snap_;
  CycleTiming timing_;
  std::array<std::uint32_t, kNumEventReasons> by_reason_{};
  std::array<SafetyEvent, kFirstEvents> first_events_{};
  std::size_t num_first_events_ = 0;
  SafetyEvent last_event_;
};

}  // namespace hyq::servo
