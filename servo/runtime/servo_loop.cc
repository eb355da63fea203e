#include "servo/runtime/servo_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "hal/clock.h"
#include "servo/runtime/command_rules.h"
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
      posture_(std::make_unique<PostureMove>(model)),
      pipeline_(std::make_unique<ControlPipeline>(model, ForClock(config.controller, config.clock),
                                                  config.friction, config.disturbance,
                                                  config.period_s())),
      controller_(&pipeline_->controller()),
      friction_(pipeline_->friction()),
      disturbance_(pipeline_->disturbance()),
      id_env_(pipeline_->environment()),
      dyn_(std::make_unique<dynamics::CycleDynamics>()),
      base_gains_(config.controller.feedback),
      command_targets_{&safety_, controller_, &env_, &base_gains_, &config_.controller.pid,
                       reference_.get(), config.safety.damp_on_bad_command} {
  for (std::size_t f = 0; f < kNumFeet; ++f) env_.mu[f] = config.mu[f];
  pipeline_->HoldEnvironment(env_);
  reference_->Sample(0.0, &ref_);
  joint_ref_ = ref_.joints;
  snap_.num_buses = static_cast<std::uint8_t>(std::min<std::size_t>(hal.num_buses(), kMaxBuses));
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
  est_status_ = estimator_.Update(hal_.image(), ref_.joints.stance); clock.Mark(&timing_.estimate_ns);
  SampleReference();                                                 clock.Mark(&timing_.reference_ns);
  RunController();                                                   clock.Mark(&timing_.control_ns);
  const SafetyDecision decision =
      safety_.Decide(safety_.mode() == ServoMode::kStopped && AllDown(hal_));
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
        config_.sit_down_s > 0.0) {
      RequestSitDown(AfterSit::kDisable);
      ++stats_.commands_applied;
      continue;
    }
    switch (ApplyCommand(cmd, est_status_, command_targets_)) {
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
    if (safety_.mode() == ServoMode::kActive && config_.sit_down_s > 0.0) {
      RequestSitDown(AfterSit::kStop);
    } else {
      safety_.Stop();
    }
  }
}

// a sit-down starts when the reference has every foot on the ground (a trot: within half a gait
// cycle), at the latest after 1 s; a stop overrides a pending disable
void ServoLoop::RequestSitDown(AfterSit then) noexcept {
  if (phase_ == Phase::kSitDown) return;
  if (!sit_pending_ || then == AfterSit::kStop) after_sit_ = then;
  sit_pending_ = true;
  const auto& st = joint_ref_.stance;
  const bool all_down = st[0] && st[1] && st[2] && st[3];
  if (all_down || phase_ == Phase::kStandUp || sit_wait_s_ >= 1.0) {
    sit_pending_ = false;
    sit_wait_s_ = 0.0;
    BeginSitDown(after_sit_);
  }
}

// the controlled stop's first part: from the measured posture down to the crouch, with the
// feet of the reference's stance on the ground and the others lowered onto it
void ServoLoop::BeginSitDown(AfterSit then) noexcept {
  VectorJ q;
  for (int j = 0; j < kNumJoints; ++j) q(j) = hal_.image().joints[static_cast<std::size_t>(j)].position_rad;
  // the reference's base velocity (a trot's), in the base frame, is braked to rest (stand-up:
  // none)
  if (phase_ == Phase::kStandUp) ref_.base = BaseReference{};
  const double c = std::cos(ref_.base.yaw), s = std::sin(ref_.base.yaw);
  const Eigen::Vector2d v0_B(c * ref_.base.v_W.x() + s * ref_.base.v_W.y(),
                             -s * ref_.base.v_W.x() + c * ref_.base.v_W.y());
  posture_->Start(q, joint_ref_.stance, config_.crouch_height_m, config_.sit_down_s, v0_B);
  phase_ = Phase::kSitDown;
  phase_t_ = 0.0;
  after_sit_ = then;
  safety_.Note(then == AfterSit::kStop ? EventReason::kStopRequest : EventReason::kDisableCommand,
               "sitting down to the crouch first");
}

// the end of a stand-up (the reference starts) or of a sit-down (the deferred request)
void ServoLoop::AdvancePhase() noexcept {
  if (phase_ == Phase::kReference || phase_t_ < posture_->duration_s()) return;
  if (phase_ == Phase::kStandUp) {
    phase_ = Phase::kReference;
    t_ref_ = 0.0;
    q0_ = joint_ref_.q;  // the enable ramp blends from the stand-up's end to the reference
    return;
  }
  sat_down_ = true;
  if (after_sit_ == AfterSit::kStop) safety_.Stop();
  else (void)safety_.Damp();  // damping, then STANDBY at 0 N·m
  phase_ = Phase::kReference;
}

void ServoLoop::CheckInputs(hal::HalStatus read_status) noexcept {
  const Fault input_fault = checker_.Check(hal_, read_status, safety_.expects_devices_in_op());
  safety_.Report(input_fault);
  // the device scan only matters while an acknowledgement waits for the devices
  if (safety_.acknowledge_pending())
    safety_.Update({.inputs_ok = !input_fault, .devices_in_op = hal_.AllIn(hal::DeviceState::kOp)});
}

void ServoLoop::EnterActive() noexcept {
  t_ref_ = 0.0;
  pipeline_->Reset();  // no integral, warm start or disturbance carried over from an earlier ACTIVE
  active_time_ = 0.0;
  for (int j = 0; j < kNumJoints; ++j)
    q0_(j) = hal_.image().joints[static_cast<std::size_t>(j)].position_rad;
  reference_->Sample(0.0, &ref_);
  phase_ = Phase::kReference;
  phase_t_ = 0.0;
  sat_down_ = false;
  sit_pending_ = false;
  sit_wait_s_ = 0.0;
  if (config_.stand_up_s > 0.0) {
    // from the resting posture, every foot on the ground, up to the reference's height
    posture_->Start(q0_, {true, true, true, true}, ref_.base.p_W.z(), config_.stand_up_s);
    phase_ = Phase::kStandUp;
  }
}

void ServoLoop::SampleReference() noexcept {
  if (safety_.mode() != ServoMode::kActive) return;  // the reference holds still outside ACTIVE
  if (phase_ != Phase::kReference) {
    if (!posture_->Sample(phase_t_, &joint_ref_))
      safety_.Report(MakeFault(EventReason::kControllerFailure, -1, -1,
                               "%s: a leg's inverse kinematics failed",
                               phase_ == Phase::kStandUp ? "stand-up" : "sit-down"));
    return;
  }
  reference_->Sample(t_ref_, &ref_);
  joint_ref_ = ref_.joints;
  // enable ramp: from the posture measured at enable to the reference (smoothstep)
  if (config_.enable_ramp_s > 0.0 && t_ref_ < config_.enable_ramp_s) {
    const double x = t_ref_ / config_.enable_ramp_s;
    const double s = x * x * (3.0 - 2.0 * x), sd = 6.0 * x * (1.0 - x) / config_.enable_ramp_s;
    const dynamics::VectorJ gap = ref_.joints.q - q0_;
    joint_ref_.q = q0_ + s * gap;
    joint_ref_.qd = s * ref_.joints.qd + sd * gap;
    joint_ref_.qdd = s * ref_.joints.qdd;
  }
}

void ServoLoop::RunController() noexcept {
  tau_.setZero();
  // outside ACTIVE the μ shown is the command's (or the last estimate below it)
  pipeline_->HoldEnvironment(env_);
  if (safety_.mode() != ServoMode::kActive) return;
  if (const Fault f = CheckEstimate(est_status_, estimator_.R_WB(), config_.safety)) {
    safety_.Report(f);
    return;
  }
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  if (const Fault f = CheckDynamics(dynamics::ComputeCycleDynamics(model_, q, v, dyn_.get()))) {
    safety_.Report(f);
    return;
  }
  VectorJ tau_m;
  const auto& joints = hal_.image().joints;
  for (int j = 0; j < kNumJoints; ++j) tau_m(j) = joints[static_cast<std::size_t>(j)].torque_Nm;
  id_status_ = pipeline_->Compute(*dyn_, q, v, tau_m, estimator_.stance(), joint_ref_, env_, &out_);
  if (out_.fallback != Fallback::kNone) ++stats_.controller_fallbacks;
  if (FellBackOnDeadline(out_)) {
    ++stats_.controller_fallbacks_deadline;
    const auto& budget = config_.controller.id.time_budget;
    if (budget && DeadlineSpentByAStall(out_, std::chrono::duration<double>(*budget).count()))
      ++stats_.controller_fallbacks_deadline_stalled;
  }
  if (const Fault f = CheckControllerOutput(controller_->kind(), id_status_, out_)) {
    safety_.Report(f);
    return;
  }
  tau_ = out_.tau_Nm;
}

void ServoLoop::Damping() noexcept {
  // after a sit-down the legs fold onto their stops under stronger damping, until the robot
  // rests (every joint slower than sit_settle_speed_rad_s for 0.2 s; at most sit_damping_max_s);
  // a fault's damping stays as configured (safety.*)
  const bool sit = sat_down_ && !safety_.damping_for_fault();
  const double D = sit ? config_.sit_damping_Nms_per_rad : config_.safety.damping_Nms_per_rad;
  double fastest = 0.0;
  for (int j = 0; j < kNumJoints; ++j) {
    const auto& in = hal_.image().joints[static_cast<std::size_t>(j)];
    const bool ok = in.valid() && std::isfinite(in.velocity_rad_s);
    tau_(j) = ok ? -D * in.velocity_rad_s : 0.0;
    fastest = ok ? std::max(fastest, std::abs(in.velocity_rad_s)) : HUGE_VAL;
  }
  if (safety_.cycles_in_mode() <= 1) settled_s_ = 0.0;
  settled_s_ = fastest < config_.sit_settle_speed_rad_s ? settled_s_ + dt_ : 0.0;
  const double in_mode_s = static_cast<double>(safety_.cycles_in_mode()) * dt_;
  safety_.HoldDamping(sit && settled_s_ < 0.2 && in_mode_s < config_.sit_damping_max_s);
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

// the deadline, the run's statistics and the reference clock
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
  safety_.Report(deadline_.Observe(used_ns, timing_.total_ns));
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
    if (sit_pending_) {
      sit_wait_s_ += dt_;
      RequestSitDown(after_sit_);  // the next cycle's reference decides; this one's may too
    }
    if (phase_ == Phase::kReference) {
      t_ref_ += dt_;
      // the run's duration is reference time: the stand-up and the sit-down come on top
      if (config_.duration_s > 0.0 && t_ref_ >= config_.duration_s) RequestStop();
    } else {
      phase_t_ += dt_;
      AdvancePhase();
    }
  }
}

void ServoLoop::PublishTelemetry(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws,
                                 ServoMode mode) noexcept {
  FillSnapshot(now_ns, rs, ws);
  if (mode == ServoMode::kActive) {
    stats_.tracking_error_sum_rad += snap_.tracking_error_rad;
    stats_.tracking_error_max_rad = std::max(stats_.tracking_error_max_rad, snap_.tracking_error_rad);
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

void ServoLoop::FillSnapshot(std::int64_t now_ns, hal::HalStatus rs, hal::HalStatus ws) noexcept {
  TelemetrySnapshot& s = snap_;
  const auto& image = hal_.image();
  s.cycle = cycle_;
  s.time_ns = now_ns;
  s.reference_time_s = t_ref_;
  s.mode = safety_.mode();
  s.controller = controller_->kind();
  double err2 = 0.0;
  for (std::size_t j = 0; j < kNumJoints; ++j) {
    const auto& in = image.joints[j];
    const int ji = static_cast<int>(j);
    s.q_rad[j] = in.position_rad;
    s.qd_rad_s[j] = in.velocity_rad_s;
    s.tau_measured_Nm[j] = in.torque_Nm;
    s.q_ref_rad[j] = joint_ref_.q(ji);
    s.qd_ref_rad_s[j] = joint_ref_.qd(ji);
    s.tau_command_Nm[j] = tau_(ji);
    s.input_status[j] = static_cast<std::uint8_t>(in.status);
    const double e = joint_ref_.q(ji) - in.position_rad;
    err2 += std::isfinite(e) ? e * e : 0.0;
  }
  s.tracking_error_rad = std::sqrt(err2);
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  for (int i = 0; i < 3; ++i) {
    s.base_position_m[static_cast<std::size_t>(i)] = q(i);
    s.base_velocity_m_s[static_cast<std::size_t>(i)] = v(i);
    s.base_angular_velocity_rad_s[static_cast<std::size_t>(i)] = v(3 + i);
  }
  for (int i = 0; i < 4; ++i) s.base_orientation_wxyz[static_cast<std::size_t>(i)] = q(3 + i);
  const bool active = safety_.mode() == ServoMode::kActive;
  for (std::size_t f = 0; f < kNumFeet; ++f) {
    s.stance_reference[f] = joint_ref_.stance[f] ? 1 : 0;
    s.stance_estimated[f] = estimator_.stance()[f] ? 1 : 0;
    s.mu[f] = id_env_.mu[f];
    const FootFriction& fr = friction_.feet()[f];
    s.mu_upper[f] = env_.mu[f];
    s.mu_estimate[f] = fr.mu;
    s.mu_confidence[f] = fr.confidence;
    s.force_ratio[f] = fr.ratio;
    s.slip_speed_m_s[f] = fr.slip_speed_m_s;
    for (int i = 0; i < 3; ++i) s.foot_force_N[f][static_cast<std::size_t>(i)] = fr.force_W(i);
    s.foot_loaded[f] = fr.loaded ? 1 : 0;
    s.foot_slipping[f] = fr.slipping ? 1 : 0;
    s.slips[f] = fr.slips;
    s.footfalls[f] = fr.footfalls;
    const auto& imp = out_.impulses[f];
    const Eigen::Vector3d F =
        active && imp.active ? Eigen::Vector3d((imp.normal_Ns * Eigen::Vector3d::UnitZ() +
                                                imp.tangent_Ns_W) / dt_)
                             : Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) s.contact_force_N[f][static_cast<std::size_t>(i)] = F(i);
  }
  s.friction_enabled = config_.friction.enabled;
  s.disturbance_enabled = config_.disturbance.enabled;
  s.disturbance_held = !active || !config_.disturbance.enabled || disturbance_.held();
  for (int i = 0; i < 3; ++i) {
    s.disturbance_force_N[static_cast<std::size_t>(i)] = disturbance_.wrench()(i);
    s.disturbance_torque_Nm[static_cast<std::size_t>(i)] = disturbance_.wrench()(3 + i);
  }
  s.stage1_status = static_cast<std::uint8_t>(out_.stage1.status);
  s.stage2_status = static_cast<std::uint8_t>(out_.stage2.status);
  s.fallback = static_cast<std::uint8_t>(out_.fallback);
  s.stage1_iterations = out_.stage1.iterations;
  s.stage2_iterations = out_.stage2.iterations;
  s.stage1_solve_us = 1e6 * out_.stage1.solve_time_s;
  s.stage2_solve_us = 1e6 * out_.stage2.solve_time_s;
  s.timing = timing_;
  s.deadline_misses = stats_.deadline_misses;
  s.consecutive_misses = stats_.consecutive_misses;
  s.skipped_cycles = stats_.skipped_cycles;
  std::size_t dev = 0;
  for (std::size_t b = 0; b < hal_.num_buses() && b < kMaxBuses; ++b) {
    const auto& c = hal_.bus(b).counters();
    BusHealth& h = s.buses[b];
    h.rx_frames = c.rx_frames;
    h.tx_frames = c.tx_frames;
    h.wkc_faults = c.wkc_faults;
    h.missing = c.missing;
    h.malformed = c.malformed;
    h.error_frames = c.error_frames;
    h.emcy = c.emcy;
    h.bus_off = c.bus_off;
    h.tx_failed = c.tx_failed;
    h.driver_dropped = c.driver_dropped;
    h.wkc_expected = hal_.bus(b).wkc().expected;
    h.wkc_received = hal_.bus(b).wkc().received;
    for (const auto& d : hal_.bus(b).devices()) {
      if (dev >= kMaxDevices) break;
      s.held_inputs[dev] = d.counters.held;
      s.max_held_in_row[dev] = d.counters.max_held_in_row;
      s.device_state[dev++] = static_cast<std::uint8_t>(d.state);
    }
  }
  s.max_held_cycles = static_cast<std::uint32_t>(config_.hal.timing.max_held_cycles);
  s.num_devices = static_cast<std::uint8_t>(dev);
  s.hal_read_status = static_cast<std::uint8_t>(rs);
  s.hal_write_status = static_cast<std::uint8_t>(ws);
  s.events = safety_.events();
}

const char* ToString(ClockMode m) noexcept {
  return m == ClockMode::kLockstep ? "lockstep" : "realtime";
}

}  // namespace hyq::servo
