#include "servo/servo_loop.h"

#include "servo/servo_runner.h"  // MonotonicNs

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace hyq::servo {
namespace {

// Every device in PRE-OP or below (a lost device is in INIT): the stop is complete.
bool AllDown(const hal::Hal& hal) noexcept {
  for (std::size_t b = 0; b < hal.num_buses(); ++b)
    for (const auto& d : hal.bus(b).devices())
      if (d.state > hal::DeviceState::kPreOp) return false;
  return true;
}

std::int64_t ThreadCpuNs() noexcept {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

Reference MakeReference(const ServoConfig& c, const dynamics::Model& m) {
  switch (c.reference) {
    case Reference::Kind::kTrot: return Reference::Trot(m, c.trot);
    case Reference::Kind::kFigureEight: return Reference::FigureEight(m, c.figure_eight);
    case Reference::Kind::kStand: break;
  }
  return Reference::Stand(m);
}

}  // namespace

ServoLoop::ServoLoop(const ServoConfig& config, const dynamics::Model& model, hal::Hal& hal,
                     TelemetrySink* sink)
    : config_(config),
      model_(model),
      hal_(hal),
      sink_(sink),
      dt_(config.period_s()),
      budget_ns_(static_cast<std::int64_t>(config.deadline.budget_fraction * config.period_s() * 1e9)),
      checker_(config.safety, config.hal),
      safety_(config.safety, config.period_s()),
      estimator_(model, config.estimator, config.period_s()),
      reference_(std::make_unique<Reference>(MakeReference(config, model))),
      controller_(std::make_unique<Controller>(model, config.controller)),
      dyn_(std::make_unique<dynamics::CycleDynamics>()),
      base_gains_(config.controller.feedback) {
  for (std::size_t f = 0; f < kNumFeet; ++f) env_.mu[f] = config.mu[f];
  reference_->Sample(0.0, &ref_);
  joint_ref_ = ref_.joints;
  snap_.num_buses = static_cast<std::uint8_t>(std::min<std::size_t>(hal.num_buses(), kTelemetryBuses));
}

ServoLoop::~ServoLoop() = default;

void ServoLoop::Start(std::int64_t now_ns) noexcept {
  safety_.BeginCycle(cycle_, now_ns);
  checker_.Reset(hal_);
  safety_.BringUpComplete();
  DrainEvents();
  published_mode_.store(safety_.mode(), std::memory_order_relaxed);
}

void ServoLoop::EnterActive() noexcept {
  t_ref_ = 0.0;
  active_time_ = 0.0;
  for (int j = 0; j < dynamics::kNumJoints; ++j)
    q0_(j) = hal_.image().joints[static_cast<std::size_t>(j)].position_rad;
  reference_->Sample(0.0, &ref_);
}

void ServoLoop::ApplyCommand(const ServoCommand& c, std::int64_t now_ns) noexcept {
  char d[96];
  switch (c.kind) {
    case ServoCommand::Kind::kEnable:
      if (est_status_ != EstimatorStatus::kOk) {
        std::snprintf(d, sizeof d, "enable refused: the state estimate is not ready (%s)",
                      ToString(est_status_));
        safety_.Note(EventReason::kCommandRejected, d);
        ++stats_.commands_rejected;
        return;
      }
      if (safety_.Enable(EventReason::kEnableCommand)) EnterActive();
      break;
    case ServoCommand::Kind::kDisable:
      (void)safety_.Disable();
      break;
    case ServoCommand::Kind::kDamp:
      if (!safety_.Damp()) {
        std::snprintf(d, sizeof d, "damp refused in %s", ToString(safety_.mode()));
        safety_.Note(EventReason::kCommandRejected, d);
      }
      break;
    case ServoCommand::Kind::kAcknowledge:
      if (safety_.mode() != ServoMode::kFault) {
        std::snprintf(d, sizeof d, "acknowledge refused in %s (only in fault)", ToString(safety_.mode()));
        safety_.Note(EventReason::kCommandRejected, d);
        break;
      }
      hal_.AcknowledgeFaults(now_ns);
      hal_.RequestState(hal::DeviceState::kOp, now_ns);
      ack_pending_ = true;
      ack_deadline_cycle_ = cycle_ + static_cast<std::uint64_t>(1.0 / dt_);  // 1 s to come back
      break;
    case ServoCommand::Kind::kSetMu:
      for (std::size_t f = 0; f < kNumFeet; ++f) env_.mu[f] = c.mu[f];
      std::snprintf(d, sizeof d, "mu = %.3f %.3f %.3f %.3f", c.mu[0], c.mu[1], c.mu[2], c.mu[3]);
      safety_.Note(EventReason::kCommandApplied, d);
      break;
    case ServoCommand::Kind::kSetController: {
      const auto kind = static_cast<ControllerKind>(c.controller);
      if (safety_.mode() == ServoMode::kActive || c.controller > 3) {
        std::snprintf(d, sizeof d, "controller change refused in %s (only outside active)",
                      ToString(safety_.mode()));
        safety_.Note(EventReason::kCommandRejected, d);
        ++stats_.commands_rejected;
        return;
      }
      controller_->SetKind(kind);
      std::snprintf(d, sizeof d, "controller = %s", ToString(kind));
      safety_.Note(EventReason::kCommandApplied, d);
      break;
    }
    case ServoCommand::Kind::kSetGains: {
      FeedbackGains g = base_gains_;
      g.kp_acc *= c.kp_scale;
      g.kp_tau *= c.kp_scale;
      g.kd_acc *= c.kd_scale;
      g.kd_tau *= c.kd_scale;
      controller_->SetFeedback(g);
      PidGains p = config_.controller.pid;
      p.kp *= c.kp_scale;
      p.kd *= c.kd_scale;
      controller_->SetPidGains(p);
      std::snprintf(d, sizeof d, "gains scaled kp x%.3f kd x%.3f", c.kp_scale, c.kd_scale);
      safety_.Note(EventReason::kCommandApplied, d);
      break;
    }
    case ServoCommand::Kind::kRejected:
      ++stats_.commands_rejected;
      if (config_.safety.damp_on_bad_command && safety_.mode() == ServoMode::kActive)
        safety_.Report(MakeFault(EventReason::kCommandRejected, -1, -1,
                                 "a refused command (sequence %llu) while active",
                                 static_cast<unsigned long long>(c.sequence)));
      return;
  }
  ++stats_.commands_applied;
}

void ServoLoop::SampleReference() noexcept {
  if (safety_.mode() != ServoMode::kActive) return;  // the reference holds still outside ACTIVE
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
  if (safety_.mode() != ServoMode::kActive) return;
  if (est_status_ != EstimatorStatus::kOk) {
    safety_.Report(MakeFault(EventReason::kEstimatorFailure, -1, -1, "estimator: %s",
                             ToString(est_status_)));
    return;
  }
  const Eigen::Matrix3d R = estimator_.R_WB();
  const double tilt = std::acos(std::clamp(R(2, 2), -1.0, 1.0));
  if (tilt > config_.safety.max_tilt_rad) {
    safety_.Report(MakeFault(EventReason::kEstimatorFailure, -1, -1,
                             "base tilt %.3f rad beyond %.3f", tilt, config_.safety.max_tilt_rad));
    return;
  }
  const VectorQ& q = estimator_.q();
  const VectorV& v = estimator_.v();
  const auto ds = dynamics::ComputeCycleDynamics(model_, q, v, dyn_.get());
  if (ds != dynamics::DynamicsStatus::kOk) {
    safety_.Report(MakeFault(EventReason::kControllerFailure, -1, -1, "dynamics: %s",
                             dynamics::ToString(ds)));
    return;
  }
  id_status_ = controller_->Compute(*dyn_, q, v, joint_ref_, env_, dt_, &out_);
  if (out_.fallback != Fallback::kNone) ++stats_.controller_fallbacks;
  if (id_status_ == IdStatus::kBadInput || out_.fallback == Fallback::kSafety ||
      !out_.tau_Nm.allFinite()) {
    safety_.Report(MakeFault(EventReason::kControllerFailure, -1, -1,
                             "controller %s: status %s, fallback %s",
                             ToString(controller_->kind()), ToString(id_status_),
                             ToString(out_.fallback)));
    return;
  }
  tau_ = out_.tau_Nm;
}

void ServoLoop::Damping() noexcept {
  const double D = config_.safety.damping_Nms_per_rad;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto& in = hal_.image().joints[static_cast<std::size_t>(j)];
    tau_(j) = in.valid() && std::isfinite(in.velocity_rad_s) ? -D * in.velocity_rad_s : 0.0;
  }
}

void ServoLoop::Cycle(std::int64_t now_ns, std::int64_t wakeup_latency_ns) noexcept {
  const std::int64_t t0 = MonotonicNs();
  // lock-step runs on virtual time: the budget there is the thread's own CPU time, so that a
  // preemption by another process (wall time the servo did not use) is not a miss
  const bool lockstep = config_.clock == ClockMode::kLockstep;
  const std::int64_t cpu0 = lockstep ? ThreadCpuNs() : 0;
  ++cycle_;
  safety_.BeginCycle(cycle_, now_ns);
  const hal::HalStatus rs = hal_.Read(now_ns);
  const std::int64_t t1 = MonotonicNs();

  // operator commands (a few per cycle at most), then a stop request
  ServoCommand cmd;
  for (int i = 0; i < 4 && sink_ != nullptr && sink_->PopCommand(&cmd); ++i) ApplyCommand(cmd, now_ns);
  // auto-enable once, as soon as the state estimate is ready (it needs an IMU reading)
  if (config_.auto_enable && safety_.mode() == ServoMode::kStandby && !safety_.stop_requested() &&
      stats_.active_cycles == 0 && est_status_ == EstimatorStatus::kOk) {
    if (safety_.Enable(EventReason::kEnableCommand)) EnterActive();
  }
  if (stop_requested_.load(std::memory_order_relaxed)) safety_.Stop();

  // inputs
  const ServoMode m0 = safety_.mode();
  const bool expect_op = m0 == ServoMode::kStandby || m0 == ServoMode::kActive ||
                         (m0 == ServoMode::kDamping && !ack_pending_);
  const Fault input_fault = checker_.Check(hal_, rs, expect_op);
  safety_.Report(input_fault);
  if (ack_pending_) {
    bool all_op = hal_.AllIn(hal::DeviceState::kOp);
    if (all_op && !input_fault) {
      ack_pending_ = !safety_.Acknowledge(true);
    } else if (cycle_ > ack_deadline_cycle_) {
      ack_pending_ = false;
      safety_.Note(EventReason::kCommandRejected, "acknowledge failed: devices not back in OP within 1 s");
    }
  }
  est_status_ = estimator_.Update(hal_.image(), ref_.joints.stance);
  const std::int64_t t2 = MonotonicNs();

  SampleReference();
  const std::int64_t t3 = MonotonicNs();

  RunController();
  const std::int64_t t4 = MonotonicNs();

  // safety: the mode decides the torque
  const ServoMode m = safety_.mode();
  if (m == ServoMode::kDamping) Damping();
  else if (m != ServoMode::kActive) tau_.setZero();
  if (m != last_mode_) {
    if (m == ServoMode::kFault) hal_.RequestState(hal::DeviceState::kSafeOp, now_ns);
    if (m == ServoMode::kStopped) {
      hal_.RequestState(hal::DeviceState::kPreOp, now_ns);
      stop_cycle_ = cycle_;
    }
    last_mode_ = m;
  }
  for (int j = 0; j < dynamics::kNumJoints; ++j)
    hal_.image().commands[static_cast<std::size_t>(j)].torque_Nm = tau_(j);
  if (m == ServoMode::kStopped &&
      (AllDown(hal_) ||
       static_cast<double>(cycle_ - stop_cycle_) * dt_ > config_.hal.timing.state_timeout_s))
    finished_ = true;
  const std::int64_t t5 = MonotonicNs();

  const hal::HalStatus ws = hal_.Write(now_ns);

  // injected overrun (fault injection): spin inside the cycle's budget
  if (overrun_cycles_.load(std::memory_order_relaxed) > 0) {
    const std::int64_t until = MonotonicNs() + overrun_ns_.load(std::memory_order_relaxed);
    while (MonotonicNs() < until) {
    }
    overrun_cycles_.fetch_sub(1, std::memory_order_relaxed);
  }
  const std::int64_t t6 = MonotonicNs();

  // deadline
  timing_.wakeup_latency_ns = wakeup_latency_ns;
  timing_.read_ns = t1 - t0;
  timing_.estimate_ns = t2 - t1;
  timing_.reference_ns = t3 - t2;
  timing_.control_ns = t4 - t3;
  timing_.safety_ns = t5 - t4;
  timing_.write_ns = t6 - t5;
  timing_.total_ns = t6 - t0;
  ++stats_.cycles;
  stats_.wakeup.Add(wakeup_latency_ns);
  stats_.cycle.Add(timing_.total_ns);
  const std::int64_t used_ns =
      lockstep ? ThreadCpuNs() - cpu0
               : timing_.total_ns + std::max<std::int64_t>(wakeup_latency_ns, 0);
  if (used_ns > budget_ns_) {
    ++stats_.deadline_misses;
    ++stats_.consecutive_misses;
    stats_.max_consecutive_misses = std::max(stats_.max_consecutive_misses, stats_.consecutive_misses);
    if (stats_.consecutive_misses >= static_cast<std::uint32_t>(config_.deadline.max_consecutive_misses))
      safety_.Report(MakeFault(EventReason::kDeadlineMiss, -1, -1,
                               "%u consecutive deadline misses (last %.1f us, budget %.1f us)",
                               stats_.consecutive_misses, 1e-3 * static_cast<double>(timing_.total_ns),
                               1e-3 * static_cast<double>(budget_ns_)));
  } else {
    stats_.consecutive_misses = 0;
  }

  if (m == ServoMode::kActive) {
    ++stats_.active_cycles;
    stats_.control.Add(timing_.control_ns);
    const double qp_us = 1e6 * (out_.stage1.solve_time_s + out_.stage2.solve_time_s);
    stats_.qp_time_sum_us += qp_us;
    stats_.qp_time_max_us = std::max(stats_.qp_time_max_us, qp_us);
    t_ref_ += dt_;
    active_time_ += dt_;
    if (config_.duration_s > 0.0 && active_time_ >= config_.duration_s) RequestStop();
  }
  FillSnapshot(now_ns, rs, ws);
  if (m == ServoMode::kActive) {
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
    ++by_reason_[static_cast<std::size_t>(e.reason) & 31u];
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
  s.controller = static_cast<std::uint8_t>(controller_->kind());
  double err2 = 0.0;
  for (std::size_t j = 0; j < kTelemetryJoints; ++j) {
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
  for (std::size_t f = 0; f < kTelemetryFeet; ++f) {
    s.stance_reference[f] = joint_ref_.stance[f] ? 1 : 0;
    s.stance_estimated[f] = estimator_.stance()[f] ? 1 : 0;
    s.mu[f] = env_.mu[f];
    const auto& imp = out_.impulses[f];
    const Eigen::Vector3d F =
        active && imp.active ? Eigen::Vector3d((imp.normal_Ns * Eigen::Vector3d::UnitZ() +
                                                imp.tangent_Ns_W) / dt_)
                             : Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) s.contact_force_N[f][static_cast<std::size_t>(i)] = F(i);
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
  for (std::size_t b = 0; b < hal_.num_buses() && b < kTelemetryBuses; ++b) {
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
    h.wkc_expected = hal_.bus(b).wkc().expected;
    h.wkc_received = hal_.bus(b).wkc().received;
    for (const auto& d : hal_.bus(b).devices())
      if (dev < kTelemetryDevices) s.device_state[dev++] = static_cast<std::uint8_t>(d.state);
  }
  s.num_devices = static_cast<std::uint8_t>(dev);
  s.hal_read_status = static_cast<std::uint8_t>(rs);
  s.hal_write_status = static_cast<std::uint8_t>(ws);
  s.events = safety_.events();
}

}  // namespace hyq::servo

namespace hyq::servo {

const char* ToString(ClockMode m) noexcept {
  return m == ClockMode::kLockstep ? "lockstep" : "realtime";
}

}  // namespace hyq::servo
