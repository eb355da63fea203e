#include "servo/runtime/servo_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "hal/clock.h"
#include "servo/runtime/output_checker.h"

namespace hyq::servo {
namespace {

// Under the lock-step clock the QPs' time budget is the servo thread's CPU time, as the deadline
// monitor's there: hyq-sim waits for the answer, and a preempted thread costs the robot nothing
// (a wall-clock budget fell back 0-2 times per 60 s of HIL trot on a shared 2-core machine).
ControllerConfig ForClock(ControllerConfig c, ClockMode clock) {
  c.id.time_budget_clock =
      clock == ClockMode::kLockstep ? qp::DeadlineClock::kThreadCpu : qp::DeadlineClock::kMonotonic;
  return c;
}

// Every device in PRE-OP or below (a lost device is in INIT): the stop is complete.
bool AllDown(const hal::Hal& hal) noexcept {
  for (std::size_t b = 0; b < hal.num_buses(); ++b)
    for (const auto& d : hal.bus(b).devices())
      if (d.state > hal::DeviceState::kPreOp) return false;
  return true;
}

MotionConfig MakeMotionConfig(const ServoConfig& c) {
  return {.stand_up_s = c.stand_up_s,
          .sit_down_s = c.sit_down_s,
          .crouch_height_m = c.crouch_height_m,
          .enable_ramp_s = c.enable_ramp_s,
          .duration_s = c.duration_s,
          .settle_speed_rad_s = c.sit_settle_speed_rad_s,
          .settle_max_s = c.sit_damping_max_s,
          .steer = c.steer,
          .steer_count = c.steer_count};
}

Reference MakeReference(const ServoConfig& c, const dynamics::Model& m) {
  switch (c.reference) {
    case Reference::Kind::kTrot: return Reference::Trot(m, c.trot);
    case Reference::Kind::kFigureEight: return Reference::FigureEight(m, c.figure_eight);
    case Reference::Kind::kStand: break;
  }
  return Reference::Stand(m);
}

// Stamps the end of each stage (wall time) into the cycle's timing.
class StageClock {
 public:
  explicit StageClock(std::int64_t t0) : last_(t0) {}
  void Mark(std::int64_t* stage_ns) noexcept {
    const std::int64_t t = MonotonicNs();
    *stage_ns = t - last_;
    last_ = t;
  }

 private:
  std::int64_t last_;
};

}  // namespace

ServoLoop::ServoLoop(const ServoConfig& config, const dynamics::Model& model, hal::Hal& hal,
                     TelemetrySink* sink)
    : config_(config),
      model_(model),
      hal_(hal),
      sink_(sink),
      dt_(config.period_s()),
      checker_(config.safety, config.hal),
      safety_(config.safety, config.period_s(), config.auto_enable,
              config.hal.timing.state_timeout_s),
      deadline_(config.deadline, config.period_s(),
                config.clock == ClockMode::kRealtime || config.deadline.stop_in_lockstep),
      estimator_(model, config.estimator, config.period_s()),
      reference_(std::make_unique<Reference>(MakeReference(config, model))),
      pipeline_(std::make_unique<ControlPipeline>(model, ForClock(config.controller, config.clock),
                                                  config.friction, config.disturbance,
                                                  config.period_s(), config.foot_force)),
      dyn_(std::make_unique<dynamics::CycleDynamics>()),
      base_gains_(config.controller.feedback),
      command_port_({&safety_, &pipeline_->controller(), &env_, &base_gains_,
                     &config_.controller.pid, reference_.get(), &est_status_}),
      sequencer_(model, reference_.get(), MakeMotionConfig(config), config.period_s(), &ref_,
                 &joint_ref_) {
  for (std::size_t f = 0; f < kNumFeet; ++f) env_.mu[f] = config.mu[f];
  pipeline_->HoldEnvironment(env_);
  safety_.SetFaultSitDown(sequencer_.sits_down());
}

ServoLoop::~ServoLoop() = default;

void ServoLoop::Start(std::int64_t now_ns) noexcept {
  safety_.BeginCycle(cycle_, now_ns);
  checker_.Reset(hal_);
  safety_.BringUpComplete();
  DrainEvents();
  published_mode_.store(safety_.mode(), std::memory_order_relaxed);
}

void ServoLoop::Cycle(std::int64_t now_ns, std::int64_t wakeup_latency_ns) noexcept {
  // lock-step runs on virtual time: the deadline there is the thread's own CPU time
  const std::int64_t cpu0 = config_.clock == ClockMode::kLockstep ? ThreadCpuNs() : 0;
  const std::int64_t start = MonotonicNs();
  StageClock clock(start);
  BeginCycle(now_ns);
  if (!answer_channels_.empty()) {
    // up to answer_wait after the cycle began (a late wake-up found the boards' answers late
    // too: a stall of the core they share), but never past (period − answer_wait) after the
    // nominal start, so that the rest of the cycle keeps its time
    const std::int64_t until = std::min(std::max(now_ns, start) + answer_wait_ns_,
                                        now_ns + period_ns_ - answer_wait_ns_);
    const std::int64_t left = until - start;
    if (left > 0 && !hal::WaitForLockstepInputs(hal_, answer_channels_, left, 0)) ++stats_.answer_wait_timeouts;
  }
  const hal::HalStatus rs = hal_.Read(now_ns);                       clock.Mark(&timing_.read_ns);
  TakeCommands(now_ns);
  CheckInputs(rs);
  estimator_.DoWithout(lost_);
  est_status_ = estimator_.Update(hal_.image(), ref_.joints.stance); clock.Mark(&timing_.estimate_ns);
  SampleReference();                                                 clock.Mark(&timing_.reference_ns);
  RunController();                                                   clock.Mark(&timing_.control_ns);
  const SafetyDecision decision = safety_.Decide(
      safety_.mode() == ServoMode::kStopped && AllDown(hal_), sequencer_.holds_damping());
  ApplyDecision(decision, now_ns);                                   clock.Mark(&timing_.safety_ns);
  const hal::HalStatus ws = hal_.Write(now_ns);
  SpinInjectedOverrun();                                             clock.Mark(&timing_.write_ns);
  EndCycle(decision, wakeup_latency_ns, cpu0);
  PublishTelemetry(now_ns, rs, ws, decision.mode);
}

void ServoLoop::BeginCycle(std::int64_t now_ns) noexcept {
  ++cycle_;
  safety_.BeginCycle(cycle_, now_ns);
}

// operator commands (a few per cycle at most), auto-enable, then a stop request
void ServoLoop::TakeCommands(std::int64_t now_ns) noexcept {
  ServoCommand cmd;
  for (int i = 0; i < 4 && sink_ != nullptr && sink_->PopCommand(&cmd); ++i) {
    // a disable while ACTIVE sits down first when configured (then damps, then 0 N·m)
    if (cmd.kind == ServoCommand::Kind::kDisable && safety_.mode() == ServoMode::kActive &&
        sequencer_.sits_down()) {
      Relay(sequencer_.RequestSitDown(SitDownCause::kDisable, MotionNow()));
      ++stats_.commands_applied;
      continue;
    }
    switch (ApplyCommand(cmd, config_.safety.damp_on_bad_command, &command_port_)) {
      case CommandOutcome::kRejected:
        ++stats_.commands_rejected;
        continue;
      case CommandOutcome::kEnabled:
        EnterActive();
        break;
      case CommandOutcome::kAcknowledging:
        hal_.AcknowledgeFaults(now_ns);
        hal_.RequestState(hal::DeviceState::kOp, now_ns);
        break;
      case CommandOutcome::kApplied:
        break;
    }
    ++stats_.commands_applied;
  }
  if (safety_.MaybeAutoEnable(est_status_ == EstimatorStatus::kOk)) EnterActive();
  if (stop_requested_.load(std::memory_order_relaxed)) {
    if (safety_.mode() == ServoMode::kActive && sequencer_.sits_down()) {
      Relay(sequencer_.RequestSitDown(SitDownCause::kStop, MotionNow()));
    } else {
      safety_.Stop();
    }
  }
}

// what the motion sequencer is told: the mode and the measured joints
MotionInputs ServoLoop::MotionNow() const noexcept {
  MotionInputs in;
  in.active = safety_.mode() == ServoMode::kActive;
  in.damping = safety_.mode() == ServoMode::kDamping;
  in.damping_cut = safety_.damping_cut();
  in.cycles_in_mode = safety_.cycles_in_mode();
  in.contacts = &contacts_;
  for (int j = 0; j < kNumJoints; ++j) {
    const auto& joint = hal_.image().joints[static_cast<std::size_t>(j)];
    in.q_rad(j) = joint.position_rad;
    const bool ok = joint.valid() && std::isfinite(joint.velocity_rad_s);
    in.fastest_joint_rad_s =
        ok ? std::max(in.fastest_joint_rad_s, std::abs(joint.velocity_rad_s)) : HUGE_VAL;
  }
  return in;
}

// what the motion sequencer asks for, told to the safety state machine
void ServoLoop::Relay(const MotionRequests& r) noexcept {
  const bool stop = r.cause == SitDownCause::kStop;
  if (r.sit_down_began && r.cause != SitDownCause::kFault)  // a fault's event says it already
    safety_.Note(stop ? EventReason::kStopRequest : EventReason::kDisableCommand,
                 "sitting down to the crouch first");
  if (r.sit_down_ended) {
    if (safety_.fault_stop() != StopClass::kNone)
      safety_.EndFaultSitDown(stop_requested_.load(std::memory_order_relaxed));
    else if (stop) safety_.Stop();
    else (void)safety_.Damp();  // damping, then STANDBY at 0 N·m
  }
  if (r.duration_over) RequestStop();
}

// a fault's stop class from what it, and every device out of OP with it, leave the daemon
// (stop_class.h); a controlled or degraded stop in ACTIVE sits down at once, without what was lost
void ServoLoop::Fail(const Fault& f) noexcept {
  if (!f) return;
  const bool active = safety_.mode() == ServoMode::kActive;
  StopClass stop = Classify(f, hal_, &lost_);
  if (active) {
    (void)ScanLost(hal_, &lost_);
    stop = StopClassOf(lost_);
  }
  safety_.Report(f, stop);
  if (safety_.fault_stop() != StopClass::kNone)
    Relay(sequencer_.RequestSitDown(SitDownCause::kFault, MotionNow()));
  ReleaseLostJoints();
}

// during the stop, a lost joint's board goes out of OP, its outputs off: a hydraulic board's valve
// closes and locks the joint where it is (one still in OP would follow 0 N·m and let it go limp);
// called where the lost set grows; the acknowledgement in FAULT asks every board back to OP
void ServoLoop::ReleaseLostJoints() noexcept {
  if (safety_.mode() != ServoMode::kActive && safety_.mode() != ServoMode::kDamping) return;
  for (int j = 0; j < kNumJoints; ++j)
    if (lost_.joint[static_cast<std::size_t>(j)]) hal_.ReleaseJoint(j);
}

void ServoLoop::CheckInputs(hal::HalStatus read_status) noexcept {
  const Fault input_fault = checker_.Check(hal_, read_status, safety_.expects_devices_in_op());
  Fail(input_fault);
  // during a fault's sit-down the first fault found each cycle may hide a device lost later:
  // its board is switched off too (below) and the sit-down goes on, or it is cut when the two
  // together are more than one device
  if (safety_.fault_stop() != StopClass::kNone && ScanLost(hal_, &lost_)) {
    if (StopClassOf(lost_) == StopClass::kCut)
      safety_.Report(MakeFault(EventReason::kInputMissing, -1, -1,
                               "more inputs lost during the sit-down (%d legs%s): cut",
                               lost_.legs(), lost_.imu ? " and the IMU" : ""),
                     StopClass::kCut);
    ReleaseLostJoints();
  }
  // the device scan only matters while an acknowledgement waits for the devices
  if (safety_.acknowledge_pending())
    safety_.Update({.inputs_ok = !input_fault, .devices_in_op = hal_.AllIn(hal::DeviceState::kOp)});
}

void ServoLoop::EnterActive() noexcept {
  lost_.Clear();  // enable comes from STANDBY: the faults were acknowledged with clean inputs
  pipeline_->Reset();  // no integral, warm start or disturbance carried over from an earlier ACTIVE
  active_time_ = 0.0;
  sequencer_.Enable(MotionNow());
}

// the motion phase's reference (outside ACTIVE it holds still)
void ServoLoop::SampleReference() noexcept {
  // the contact-aware gait follows the feet's ground forces (the last cycle's momentum observer:
  // foot_force_observer.h) and the estimator's kinematics (reference.h)
  const VectorQ& q = estimator_.q();
  for (std::size_t f = 0; f < kNumFeet; ++f) {
    contacts_.probability[f] = pipeline_->feet().probability()[f];
    contacts_.vertical_speed_m_s[f] = std::abs(estimator_.feet()[f].point_velocity_W.z());
  }
  contacts_.q = q.tail<kNumJoints>();
  contacts_.base_height_m = q(2);
  contacts_.R_WB = estimator_.R_WB();
  if (!sequencer_.Sample(MotionNow()))
    Fail(MakeFault(EventReason::kControllerFailure, -1, -1,
                             "%s: a leg's inverse kinematics failed",
                             ToString(sequencer_.phase())));
}

// the load cells' joint torques of this cycle's process image
VectorJ ServoLoop::MeasuredTorque() const noexcept {
  VectorJ tau_m;
  const auto& joints = hal_.image().joints;
  for (int j = 0; j < kNumJoints; ++j) {
    const double tau = joints[static_cast<std::size_t>(j)].torque_Nm;
    // a lost joint's load cell (a fault's stop does without it) reads nothing
    tau_m(j) = lost_.joint[static_cast<std::size_t>(j)] || !std::isfinite(tau) ? 0.0 : tau;
  }
  return tau_m;
}

void ServoLoop::RunController() noexcept {
  tau_.setZero();
  // outside ACTIVE the μ shown is the command's (or the last estimate below it)
  pipeline_->HoldEnvironment(env_);
  if (safety_.mode() == ServoMode::kDamping && sequencer_.settling()) return ObserveFeet();
  if (safety_.mode() != ServoMode::kActive) return;
  if (const Fault f = CheckEstimate(est_status_, estimator_.R_WB(), config_.safety)) {
    Fail(f);
    return;
  }
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  if (const Fault f = CheckDynamics(dynamics::ComputeCycleDynamics(model_, q, v, dyn_.get()))) {
    Fail(f);
    return;
  }
  const VectorJ tau_m = MeasuredTorque();
  id_status_ = pipeline_->Compute(*dyn_, q, v, tau_m, estimator_.stance(), estimator_.slip_evidence(),
                                  joint_ref_, env_, &out_);
  if (out_.fallback != Fallback::kNone) ++stats_.controller_fallbacks;
  if (FellBackOnDeadline(out_)) {
    ++stats_.controller_fallbacks_deadline;
    const auto& budget = config_.controller.id.time_budget;
    if (budget && DeadlineSpentByAStall(out_, std::chrono::duration<double>(*budget).count()))
      ++stats_.controller_fallbacks_deadline_stalled;
  }
  if (const Fault f = CheckControllerOutput(pipeline_->controller().kind(), id_status_, out_)) {
    Fail(f);
    return;
  }
  tau_ = out_.tau_Nm;
  // a lost joint is left to its board (limp once it leaves OP): no torque computed without it
  for (int j = 0; j < kNumJoints; ++j)
    if (lost_.joint[static_cast<std::size_t>(j)]) tau_(j) = 0.0;
}

// after a sit-down, which feet still carry the trunk (the feet's force observer; outside ACTIVE
// the controller does not run it): a settling cycle whose estimate fails takes every foot as
// loaded
void ServoLoop::ObserveFeet() noexcept {
  feet_known_ = false;
  if (CheckEstimate(est_status_, estimator_.R_WB(), config_.safety)) return;
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  if (dynamics::ComputeCycleDynamics(model_, q, v, dyn_.get()) != dynamics::DynamicsStatus::kOk) return;
  const VectorJ tau_m = MeasuredTorque();
  pipeline_->ObserveFeet(*dyn_, v, tau_m);
  feet_known_ = true;
}

void ServoLoop::Damping() noexcept {
  // after a sit-down the legs fold onto their stops under the sit-down's damping
  // (motion_sequencer.h, SETTLE), on the legs whose feet still carry the trunk; a leg whose foot
  // is off the ground is light, and the damping that slows a loaded leg's fold rings it behind
  // the actuator's lag and the loop's delay (docs/tuning.md, "Loop model"): it gets
  // sit_damping_light_fraction of it; so does a leg whose foot moves up or down (a foot that
  // hammers the ground or its leg's stop: the damping behind the same lag drives it).
  // A fault's damping stays as configured (safety.*).
  const bool settling = sequencer_.settling();
  const double D = settling ? config_.sit_damping_Nms_per_rad : config_.safety.damping_Nms_per_rad;
  const double light = config_.sit_damping_light_fraction;
  for (int j = 0; j < kNumJoints; ++j) {
    const auto& in = hal_.image().joints[static_cast<std::size_t>(j)];
    const bool ok = in.valid() && std::isfinite(in.velocity_rad_s);
    double scale = 1.0;
    if (settling) {
      const auto leg = static_cast<std::size_t>(j / dynamics::kJointsPerLeg);
      const bool still = std::abs(estimator_.feet()[leg].point_velocity_W.z()) <=
                         config_.trot.touchdown.still_speed_m_s;
      // without the IMU the feet's speeds are the estimate's guess: every leg damped in full
      const double loaded = !feet_known_ || lost_.imu ? 1.0 : still ? pipeline_->feet().probability()[leg] : 0.0;
      scale = light + (1.0 - light) * loaded;
    }
    tau_(j) = ok ? -D * scale * in.velocity_rad_s : 0.0;
  }
}

// the safety decision applied: the torque the mode allows, the devices' requested state
void ServoLoop::ApplyDecision(const SafetyDecision& d, std::int64_t now_ns) noexcept {
  if (d.torque == SafetyDecision::Torque::kDamping) Damping();
  else if (d.torque == SafetyDecision::Torque::kZero) tau_.setZero();
  if (d.request_devices) hal_.RequestState(d.device_request, now_ns);
  for (int j = 0; j < kNumJoints; ++j)
    hal_.image().commands[static_cast<std::size_t>(j)].torque_Nm = tau_(j);
  if (d.finished) finished_ = true;
}

// fault injection: spin inside the cycle's budget
void ServoLoop::SpinInjectedOverrun() noexcept {
  if (overrun_cycles_.load(std::memory_order_relaxed) <= 0) return;
  const std::int64_t until = MonotonicNs() + overrun_ns_.load(std::memory_order_relaxed);
  while (MonotonicNs() < until) {
  }
  overrun_cycles_.fetch_sub(1, std::memory_order_relaxed);
}

// the deadline, the run's statistics and, after an ACTIVE cycle, the motion phase's clock (its
// requests take effect from the next cycle's start)
void ServoLoop::EndCycle(const SafetyDecision& d, std::int64_t wakeup_latency_ns,
                         std::int64_t cpu0) noexcept {
  timing_.wakeup_latency_ns = wakeup_latency_ns;
  timing_.total_ns = timing_.read_ns + timing_.estimate_ns + timing_.reference_ns +
                     timing_.control_ns + timing_.safety_ns + timing_.write_ns;
  ++stats_.cycles;
  stats_.wakeup.Add(wakeup_latency_ns);
  stats_.cycle.Add(timing_.total_ns);
  const std::int64_t used_ns = config_.clock == ClockMode::kLockstep
                                   ? ThreadCpuNs() - cpu0
                                   : timing_.total_ns + std::max<std::int64_t>(wakeup_latency_ns, 0);
  Fail(deadline_.Observe(used_ns, timing_.total_ns));
  stats_.deadline_misses = deadline_.misses();
  stats_.consecutive_misses = deadline_.consecutive();
  stats_.max_consecutive_misses = deadline_.max_consecutive();

  if (d.mode == ServoMode::kActive) {
    ++stats_.active_cycles;
    stats_.control.Add(timing_.control_ns);
    const double qp_us = 1e6 * (out_.stage1.solve_time_s + out_.stage2.solve_time_s);
    stats_.qp_time_sum_us += qp_us;
    stats_.qp_time_max_us = std::max(stats_.qp_time_max_us, qp_us);
    active_time_ += dt_;
    Relay(sequencer_.Advance(MotionNow()));
  }
}

void ServoLoop::PublishTelemetry(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws,
                                 ServoMode mode) noexcept {
  FillSnapshot(now_ns, rs, ws);
  if (mode == ServoMode::kActive) {
    const double error_rad = snap_.joint_state.tracking_error_rad;
    stats_.tracking_error_sum_rad += error_rad;
    stats_.tracking_error_max_rad = std::max(stats_.tracking_error_max_rad, error_rad);
    // the knees' margin to the safety's speed limit, the number the gains are chosen by
    for (int j = 0; j < kNumJoints; ++j) {
      const auto& joint = hal_.image().joints[static_cast<std::size_t>(j)];
      const double speed = std::abs(joint.velocity_rad_s);
      if (joint.valid() && speed > stats_.joint_speed_max_rad_s) {
        stats_.joint_speed_max_rad_s = speed;
        stats_.joint_speed_max_joint = j;
        stats_.joint_speed_max_at_s = active_time_;
      }
    }
  }
  if (sink_ != nullptr && !sink_->Push(snap_)) ++stats_.telemetry_drops;
  DrainEvents();
  published_mode_.store(safety_.mode(), std::memory_order_relaxed);
  published_cycles_.store(cycle_, std::memory_order_relaxed);
  published_active_s_.store(active_time_, std::memory_order_relaxed);
}

void ServoLoop::DrainEvents() noexcept {
  SafetyEvent e;
  while (safety_.Take(&e)) {
    if (static_cast<std::size_t>(e.reason) < by_reason_.size()) ++by_reason_[static_cast<std::size_t>(e.reason)];
    if (num_first_events_ < first_events_.size()) first_events_[num_first_events_++] = e;
    last_event_ = e;
    if (sink_ != nullptr && !sink_->PushEvent(e)) ++stats_.event_drops;
  }
}

// Writes this cycle's values into the snapshot's messages (utime, cycle and the health message's
// telemetry counters are the telemetry thread's to set).
void ServoLoop::FillSnapshot(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws) noexcept {
  TelemetrySnapshot& s = snap_;
  const auto& image = hal_.image();
  const auto mode = static_cast<std::int8_t>(safety_.mode());
  const auto controller = static_cast<std::int8_t>(pipeline_->controller().kind());
  s.cycle = cycle_;
  s.time_ns = now_ns;

  hyq_lcm::lcmt_hyq_joint_state& js = s.joint_state;
  hyq_lcm::lcmt_hyq_joint_torque& jt = s.joint_torque;
  js.mode = mode;
  js.reference_time_s = sequencer_.reference_time_s();
  jt.mode = mode;
  jt.controller = controller;
  double err2 = 0.0;
  for (std::size_t j = 0; j < kNumJoints; ++j) {
    const auto& in = image.joints[j];
    const int ji = static_cast<int>(j);
    js.q_rad[j] = in.position_rad;
    js.qd_rad_s[j] = in.velocity_rad_s;
    js.tau_measured_Nm[j] = in.torque_Nm;
    js.q_ref_rad[j] = joint_ref_.q(ji);
    js.qd_ref_rad_s[j] = joint_ref_.qd(ji);
    js.input_status[j] = static_cast<std::int8_t>(in.status);
    jt.tau_command_Nm[j] = tau_(ji);
    const double e = joint_ref_.q(ji) - in.position_rad;
    err2 += std::isfinite(e) ? e * e : 0.0;
  }
  js.tracking_error_rad = std::sqrt(err2);

  hyq_lcm::lcmt_hyq_base_state& base = s.base_state;
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  for (int i = 0; i < 3; ++i) {
    base.position_m[i] = q(i);
    base.velocity_m_s[i] = v(i);
    base.angular_velocity_rad_s[i] = v(3 + i);
  }
  for (int i = 0; i < 4; ++i) base.orientation_wxyz[i] = q(3 + i);
  const Eigen::Vector3d p_std = estimator_.position_std_m(), v_std = estimator_.velocity_std_m_s(),
                        o_std = estimator_.orientation_std_rad();
  for (int i = 0; i < 3; ++i) {
    base.position_std_m[i] = p_std(i);
    base.velocity_std_m_s[i] = v_std(i);
    base.orientation_std_rad[i] = o_std(i);
    base.gyro_bias_rad_s[i] = estimator_.gyro_bias_rad_s()(i);
    base.accel_bias_m_s2[i] = estimator_.accel_bias_m_s2()(i);
  }
  base.still = estimator_.still() ? 1 : 0;

  hyq_lcm::lcmt_hyq_contact_state& c = s.contact;
  hyq_lcm::lcmt_hyq_friction_estimate& fe = s.friction;
  const bool active = safety_.mode() == ServoMode::kActive;
  c.controller = controller;
  fe.enabled = config_.friction.enabled;
  for (std::size_t f = 0; f < kNumFeet; ++f) {
    c.stance_reference[f] = joint_ref_.stance[f] ? 1 : 0;
    c.stance_estimated[f] = estimator_.stance()[f] ? 1 : 0;
    const FootEstimate& fe_est = estimator_.feet()[f];
    c.contact_probability[f] = fe_est.contact_probability;
    c.foot_used[f] = fe_est.used ? 1 : 0;
    c.foot_rejected[f] = fe_est.rejected ? 1 : 0;
    c.foot_mahalanobis_sq[f] = fe_est.mahalanobis_sq;
    c.foot_rejections[f] = static_cast<std::int32_t>(std::min<std::int64_t>(fe_est.rejections, std::numeric_limits<std::int32_t>::max()));
    c.mu[f] = pipeline_->environment().mu[f];
    const auto& imp = out_.impulses[f];
    const Eigen::Vector3d F =
        active && imp.active ? Eigen::Vector3d((imp.normal_Ns * Eigen::Vector3d::UnitZ() +
                                                imp.tangent_Ns_W) / dt_)
                             : Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) c.contact_force_N[f][i] = F(i);
    const Eigen::Vector3d& G = pipeline_->feet().force_W()[f];
    for (int i = 0; i < 3; ++i) c.ground_force_N[f][i] = G(i);
    c.landed_probability[f] = contacts_.probability[f];
    c.gait_phase[f] = static_cast<std::int8_t>(ref_.feet[f].phase);
    const FootFriction& fr = pipeline_->friction().feet()[f];
    fe.mu_estimate[f] = fr.mu;
    fe.mu_control[f] = pipeline_->environment().mu[f];
    fe.mu_upper[f] = env_.mu[f];
    fe.confidence[f] = fr.confidence;
    fe.force_ratio[f] = fr.ratio;
    fe.slip_speed_m_s[f] = fr.slip_speed_m_s;
    for (int i = 0; i < 3; ++i) fe.force_N[f][i] = fr.force_W(i);
    fe.loaded[f] = fr.loaded ? 1 : 0;
    fe.slipping[f] = fr.slipping ? 1 : 0;
    fe.slips[f] = static_cast<std::int32_t>(fr.slips);
    fe.footfalls[f] = static_cast<std::int32_t>(fr.footfalls);
    fe.evidence_held[f] = fr.evidence_held ? 1 : 0;
    fe.held_cycles[f] = static_cast<std::int32_t>(std::min<std::int64_t>(
        static_cast<std::int64_t>(fr.held_cycles), std::numeric_limits<std::int32_t>::max()));
  }
  c.stage1_status = static_cast<std::int8_t>(out_.stage1.status);
  c.stage2_status = static_cast<std::int8_t>(out_.stage2.status);
  c.fallback = static_cast<std::int8_t>(out_.fallback);
  c.stage1_iterations = out_.stage1.iterations;
  c.stage2_iterations = out_.stage2.iterations;
  c.stage1_solve_us = 1e6 * out_.stage1.solve_time_s;
  c.stage2_solve_us = 1e6 * out_.stage2.solve_time_s;

  hyq_lcm::lcmt_hyq_disturbance_estimate& d = s.disturbance;
  d.enabled = config_.disturbance.enabled;
  d.held = !active || !config_.disturbance.enabled || pipeline_->disturbance().held();
  for (int i = 0; i < 3; ++i) {
    d.force_N[i] = pipeline_->disturbance().wrench()(i);
    d.torque_Nm[i] = pipeline_->disturbance().wrench()(3 + i);
  }
  d.payload_kg = -d.force_N[2] / 9.81;

  hyq_lcm::lcmt_hyq_servo_timing& t = s.timing;
  t.wakeup_latency_ns = timing_.wakeup_latency_ns;
  t.read_ns = timing_.read_ns;
  t.estimate_ns = timing_.estimate_ns;
  t.reference_ns = timing_.reference_ns;
  t.control_ns = timing_.control_ns;
  t.safety_ns = timing_.safety_ns;
  t.write_ns = timing_.write_ns;
  t.total_ns = timing_.total_ns;
  t.deadline_misses = static_cast<std::int64_t>(stats_.deadline_misses);
  t.consecutive_misses = static_cast<std::int32_t>(stats_.consecutive_misses);
  t.skipped_cycles = static_cast<std::int64_t>(stats_.skipped_cycles);

  hyq_lcm::lcmt_hyq_health& h = s.health;
  h.mode = mode;
  h.hal_read_status = static_cast<std::int8_t>(rs);
  h.hal_write_status = static_cast<std::int8_t>(ws);
  const std::size_t num_buses = std::min<std::size_t>(hal_.num_buses(), kMaxBuses);
  h.num_buses = static_cast<std::int8_t>(num_buses);
  std::size_t dev = 0;
  for (std::size_t b = 0; b < num_buses; ++b) {
    const auto& counters = hal_.bus(b).counters();
    hyq_lcm::lcmt_hyq_bus_health& bh = h.buses[b];
    bh.rx_frames = static_cast<std::int64_t>(counters.rx_frames);
    bh.tx_frames = static_cast<std::int64_t>(counters.tx_frames);
    bh.wkc_faults = static_cast<std::int64_t>(counters.wkc_faults);
    bh.missing = static_cast<std::int64_t>(counters.missing);
    bh.malformed = static_cast<std::int64_t>(counters.malformed);
    bh.error_frames = static_cast<std::int64_t>(counters.error_frames);
    bh.emcy = static_cast<std::int64_t>(counters.emcy);
    bh.bus_off = static_cast<std::int64_t>(counters.bus_off);
    bh.tx_failed = static_cast<std::int64_t>(counters.tx_failed);
    bh.driver_dropped = static_cast<std::int64_t>(counters.driver_dropped);
    bh.wkc_expected = static_cast<std::int32_t>(hal_.bus(b).wkc().expected);
    bh.wkc_received = static_cast<std::int32_t>(hal_.bus(b).wkc().received);
    for (const auto& device : hal_.bus(b).devices()) {
      if (dev >= kMaxDevices) break;
      h.device_state[dev] = static_cast<std::int8_t>(device.state);
      h.held_inputs[dev] = static_cast<std::int64_t>(device.counters.held);
      h.max_held_in_row[dev] = static_cast<std::int32_t>(device.counters.max_held_in_row);
      ++dev;
    }
  }
  h.num_devices = static_cast<std::int8_t>(dev);
  h.max_held_cycles = static_cast<std::int16_t>(std::min(config_.hal.timing.max_held_cycles, 32767));
  h.safety_events = static_cast<std::int64_t>(safety_.events());
}

const char* ToString(ClockMode m) noexcept {
  return m == ClockMode::kLockstep ? "lockstep" : "realtime";
}

}  // namespace hyq::servo
