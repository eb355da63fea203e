#include "tools/sim/simulated_robot.h"

#include <poll.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <thread>

#include <Eigen/Geometry>

#include "hal/clock.h"
#include "hal/config_error.h"
#include "servo/reference/reference.h"
#include "hal/config_error.h"
#include "hal/protocol.h"

namespace hyq::sim {

/// The device side of one bus, counting the SYNCs that arrive (even those the emulator ignores,
/// e.g. while its bus is off), so that lock-step follows the master's SYNCs on the wire.
class SimulatedRobot::SyncCounter final : public hal::CanChannel {
 public:
  explicit SyncCounter(hal::CanChannel* inner) : inner_(inner) {}
  hal::CanStatus Send(std::span<const hal::CanFrame> f, std::size_t* sent) noexcept override {
    return inner_->Send(f, sent);
  }
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override {
    const hal::CanStatus s = inner_->Receive(out, received);
    for (std::size_t i = 0; i < *received; ++i) {
      const hal::CanFrame& f = out[i];
      if (f.id == hal::cob::kSync && !f.is_extended() && !f.is_error()) ++syncs_;
    }
    return s;
  }
  const hal::CanCounters& counters() const noexcept override { return inner_->counters(); }
  bool fd_enabled() const noexcept override { return inner_->fd_enabled(); }
  std::string_view name() const noexcept override { return inner_->name(); }
  int poll_fd() const noexcept override { return inner_->poll_fd(); }
  std::uint64_t syncs() const noexcept { return syncs_; }

 private:
  hal::CanChannel* inner_;
  std::uint64_t syncs_ = 0;
};

SimulatedRobot::SimulatedRobot(const dynamics::Model& model, const hal::HalConfig& config,
                               std::span<hal::CanChannel* const> channels,
                               const SimulatedRobotConfig& cfg)
    : model_(model),
      config_(config),
      cfg_(cfg),
      period_ns_(std::llround(config.timing.cycle_period_s * 1e9)),
      holding_(cfg.hold),
      min_base_height_m_(model.standing_base_height_m),
      rng_(cfg.seed == 0 ? 0x9E3779B97F4A7C15ull : cfg.seed) {
  if (!(cfg.actuator_tau_s >= 0) || !(cfg.actuator_rate_limit_Nm_s >= 0) ||
      !(cfg.encoder_noise_rad >= 0) || !(cfg.load_cell_noise_Nm >= 0) ||
      !(cfg.gyro_noise_rad_s >= 0) || !(cfg.accel_noise_m_s2 >= 0))
    throw hal::ConfigError("simulated robot: time constants, rate limits and noise levels must be "
                           ">= 0");
  if (channels.size() != config.buses.size())
    throw hal::ConfigError("simulated robot: " + std::to_string(config.buses.size()) +
                           " buses configured but " + std::to_string(channels.size()) +
                           " CAN channels given");
  std::vector<hal::CanChannel*> wrapped;
  for (hal::CanChannel* c : channels) {
    if (c == nullptr) throw hal::ConfigError("simulated robot: a CAN channel is missing");
    channels_.push_back(std::make_unique<SyncCounter>(c));
    wrapped.push_back(channels_.back().get());
  }
  emulator_ = std::make_unique<hal::Emulator>(config_, wrapped, cfg.seed);
  PlantConfig pc = cfg.plant;
  pc.timestep_s = config.timing.cycle_period_s;
  pc.imu_sensor = true;
  cfg.profile.ApplyTo(&pc);
  try {
    plant_ = std::make_unique<Plant>(model, pc);
    actuation_ = std::make_unique<Actuation>(model, config.joints, cfg.profile, cfg.actuator_tau_s,
                                             cfg.actuator_rate_limit_Nm_s,
                                             config.timing.cycle_period_s);
  } catch (const std::invalid_argument& e) {
    throw hal::ConfigError(std::string("simulated robot: ") + e.what());
  }
  gyro_bias_ = cfg.gyro_bias_rad_s + cfg.profile.GyroBias();
  accel_bias_ = cfg.accel_bias_m_s2 + cfg.profile.AccelBias();
  q_hold_ = model.StandingQ();
  if (cfg.start_height_m > 0.0) {
    // the resting posture: the standing feet's places, the base lowered, by the legs' IK
    servo::Reference rest = servo::Reference::Stand(model, cfg.start_height_m);
    servo::ReferenceSample s;
    rest.Sample(0.0, &s);
    if (s.ik != dynamics::IkStatus::kOk)
      throw hal::ConfigError("simulated robot: start height " + std::to_string(cfg.start_height_m) +
                             " m: expected a height the legs reach with the feet on the ground, found " +
                             dynamics::ToString(s.ik));
    q_hold_(2) = cfg.start_height_m;
    q_hold_.tail<dynamics::kNumJoints>() = s.joints.q;
  }
  plant_->Reset(q_hold_, dynamics::VectorV::Zero());
  actuation_->Reset(q_hold_.tail<dynamics::kNumJoints>());
  R_BF_ = model.imu.R_BF;
  UpdateSensors();
}

SimulatedRobot::~SimulatedRobot() = default;

void SimulatedRobot::ScheduleFault(const FaultSpec& f) {
  faults_.push_back(f);
  fault_state_.push_back(0);
}

double SimulatedRobot::time_s() const noexcept {
  return static_cast<double>(counters_.steps) * config_.timing.cycle_period_s;
}

double SimulatedRobot::Gaussian() noexcept {
  // Marsaglia's polar method on xorshift64* uniforms (the same numbers on every platform)
  if (has_spare_) {
    has_spare_ = false;
    return spare_gaussian_;
  }
  auto uniform = [this] {
    rng_ ^= rng_ >> 12;
    rng_ ^= rng_ << 25;
    rng_ ^= rng_ >> 27;
    return static_cast<double>((rng_ * 2685821657736338717ull) >> 11) * 0x1.0p-53;
  };
  double u = 0, v = 0, s = 0;
  do {
    u = 2 * uniform() - 1;
    v = 2 * uniform() - 1;
    s = u * u + v * v;
  } while (s >= 1 || s == 0);
  const double m = std::sqrt(-2 * std::log(s) / s);
  spare_gaussian_ = v * m;
  has_spare_ = true;
  return u * m;
}

void SimulatedRobot::ApplyFaults(double t_s) noexcept {
  const double t = t_s + 1e-9;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    std::uint8_t& st = fault_state_[i];
    if (st == 0 && t >= f.t_s) {
      st = f.duration_s > 0 ? 1 : 2;
      ++counters_.faults_injected;
      hal::DeviceFaults& x =
          f.joint == FaultSpec::kImuTarget ? emulator_->imu_faults() : emulator_->joint_faults(f.joint);
      switch (f.kind) {
        case FaultSpec::Kind::kSilent: x.silent = true; break;
        case FaultSpec::Kind::kCorrupt: x.corrupt_next += f.count; break;
        case FaultSpec::Kind::kDrop: x.drop_next += f.count; break;
        case FaultSpec::Kind::kNan:
          // a broken load cell: garbage counts with the sensor-fault bit, and the board (whose
          // torque loop needs the sensor) latches a fault and reports it
          x.sensor_fault = true;
          if (f.joint >= 0) emulator_->SendJointEmcy(f.joint, hal::emcy::kSensor);
          break;
        case FaultSpec::Kind::kBusOff: emulator_->SetBusOff(f.bus, true); break;
        case FaultSpec::Kind::kEmcy: emulator_->SendJointEmcy(f.joint, f.emcy_code); break;
      }
    } else if (st == 1 && t >= f.t_s + f.duration_s) {
      st = 2;
      if (f.kind == FaultSpec::Kind::kBusOff) emulator_->SetBusOff(f.bus, false);
      if (f.kind == FaultSpec::Kind::kSilent)
        (f.joint == FaultSpec::kImuTarget ? emulator_->imu_faults()
                                          : emulator_->joint_faults(f.joint))
            .silent = false;
    }
  }
}

void SimulatedRobot::Step() noexcept {
  // actuators: saturation, then (Actuation) the delay and the first-order lag (1) with its rate
  // limit, or the hydraulics with the board's torque loop
  bool all_enabled = true, commanding = false;
  constexpr double kReleaseTorqueNm = 0.0;  // any non-zero set-point (1 mN·m resolution)
  dynamics::VectorJ u;
  if (bus_thread_owns_emulator_) {
    SetpointFrame f;
    while (setpoint_frames_.TryPop(&f)) setpoints_ = f;  // the newest the boards hold
  } else {
    ApplyFaults(time_s());
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      const auto i = static_cast<std::size_t>(j);
      setpoints_.tau[i] = emulator_->torque_setpoint_Nm(j);
      setpoints_.enabled[i] = emulator_->outputs_enabled(j);
    }
  }
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const double limit = std::min(config_.joints[i].torque_limit_Nm, model_.limits[i].effort_Nm);
    all_enabled = all_enabled && setpoints_.enabled[i];
    commanding = commanding || std::abs(setpoints_.tau[i]) > kReleaseTorqueNm;
    u(j) = std::clamp(setpoints_.tau[i], -limit, limit);
  }
  {
    const dynamics::VectorQ q = plant_->q();
    const dynamics::VectorV v = plant_->v();
    actuation_->Step(u, q.tail<dynamics::kNumJoints>(), v.tail<dynamics::kNumJoints>());
  }
  tau_applied_ = actuation_->applied_Nm();
  // off the stand once every board is enabled AND the controller commands torque: a daemon in
  // STANDBY (enabled, 0 N·m) keeps the robot on its stand, as an operator would
  if (holding_ && all_enabled && commanding) holding_ = false;
  if (holding_) {
    plant_->Reset(q_hold_, dynamics::VectorV::Zero());  // on the stand
    ++counters_.held_steps;
  } else {
    plant_->Step(tau_applied_);
  }
  ++counters_.steps;
  sim_now_ns_.store(time_ns(), std::memory_order_relaxed);
  const double z = plant_->q()(2);
  min_base_height_m_ = std::min(min_base_height_m_, z);
  if (!holding_) max_descent_m_s_ = std::max(max_descent_m_s_, -plant_->v()(2));
  if (!fell_ && !holding_) {
    const dynamics::VectorQ q = plant_->q();
    const double up = Eigen::Quaterniond(q(3), q(4), q(5), q(6)).toRotationMatrix()(2, 2);
    const bool contact = z < cfg_.fall_height_m || plant_->BodyTouchesGround();
    if (contact && !sat_down_) {
      contact_speed_m_s_ = -plant_->v()(2);
      const bool gentle = contact_speed_m_s_ <= cfg_.max_sit_speed_m_s && up > std::cos(M_PI / 6);
      (gentle ? sat_down_ : fell_) = true;
      (gentle ? sat_down_at_s_ : fell_at_s_) = time_s();
    } else if (sat_down_ && up < std::cos(M_PI / 4)) {
      fell_ = true;  // sat down, then tipped over
      fell_at_s_ = time_s();
    }
  }
  UpdateSensors();
  if (observer_) observer_(*this);
}

void SimulatedRobot::UpdateSensors() noexcept {
  const dynamics::VectorQ q = plant_->q();
  const dynamics::VectorV v = plant_->v();
  SensorFrame f;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    double qj = q(7 + j);
    if (cfg_.encoder_noise_rad > 0) qj += cfg_.encoder_noise_rad * Gaussian();
    f.q[i] = qj;
    f.v[i] = v(6 + j);
    double tau = actuation_->measured_Nm()(j);  // the actuator's output plus the load-cell bias
    if (cfg_.load_cell_noise_Nm > 0) tau += cfg_.load_cell_noise_Nm * Gaussian();
    tau_measured_(j) = tau;
    f.tau[i] = tau;
  }
  ImuReading r;
  if (holding_) {
    // at rest on the stand: no rotation, the specific force is -g
    const Eigen::Quaterniond quat(q(3), q(4), q(5), q(6));
    r.specific_force_m_s2 = (quat.toRotationMatrix() * R_BF_).transpose() * (-model_.gravity_W);
  } else {
    r = plant_->Imu();
  }
  r.gyro_rad_s += gyro_bias_;
  r.specific_force_m_s2 += accel_bias_;
  if (cfg_.gyro_noise_rad_s > 0)
    for (int i = 0; i < 3; ++i) r.gyro_rad_s(i) += cfg_.gyro_noise_rad_s * Gaussian();
  if (cfg_.accel_noise_m_s2 > 0)
    for (int i = 0; i < 3; ++i) r.specific_force_m_s2(i) += cfg_.accel_noise_m_s2 * Gaussian();
  imu_reported_ = r;
  f.gyro = {r.gyro_rad_s(0), r.gyro_rad_s(1), r.gyro_rad_s(2)};
  f.accel = {r.specific_force_m_s2(0), r.specific_force_m_s2(1), r.specific_force_m_s2(2)};
  if (bus_thread_owns_emulator_) {
    (void)sensor_frames_.TryPush(f);  // full: the bus thread is stalled; it takes the next step's
    return;
  }
  SetEmulatorSensors(f);
}

void SimulatedRobot::SetEmulatorSensors(const SensorFrame& f) noexcept {
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    emulator_->SetJointState(j, f.q[i], f.v[i], f.tau[i]);
  }
  emulator_->SetImu(f.gyro, f.accel);
}

void SimulatedRobot::Poll(std::int64_t now_ns) noexcept {
  emulator_->Poll(now_ns);
  for (std::size_t b = 0; b < channels_.size(); ++b) counters_.syncs[b] = channels_[b]->syncs();
}

int SimulatedRobot::PollLockStep() noexcept {
  Poll(time_ns());
  int steps = 0;
  for (;;) {
    std::uint64_t lo = UINT64_MAX, hi = 0;
    for (std::size_t b = 0; b < channels_.size(); ++b) {
      lo = std::min(lo, counters_.syncs[b]);
      hi = std::max(hi, counters_.syncs[b]);
    }
    // every bus saw SYNC k; or a bus fell kMaxSyncLead behind (the master gave up on it)
    const std::uint64_t target = std::max(lo, hi > kMaxSyncLead ? hi - kMaxSyncLead : 0);
    if (counters_.steps >= target) break;
    if (lo <= counters_.steps) ++counters_.lockstep_forced;
    Step();
    ++steps;
  }
  return steps;
}

int SimulatedRobot::WaitAndPollLockStep(int timeout_ms) noexcept {
  const int stepped = PollLockStep();
  if (stepped > 0) return stepped;
  std::array<pollfd, hal::kMaxBuses> fds{};
  nfds_t n = 0;
  for (const auto& c : channels_)
    if (c->poll_fd() >= 0) fds[n++] = {c->poll_fd(), POLLIN, 0};
  if (n == 0) return 0;
  (void)poll(fds.data(), n, timeout_ms);
  return PollLockStep();
}

std::uint64_t SimulatedRobot::RunLockStep(const std::atomic<bool>& stop, double duration_s) {
  const auto end_steps = duration_s > 0
                             ? static_cast<std::uint64_t>(std::llround(duration_s * 1e9 / static_cast<double>(period_ns_)))
                             : UINT64_MAX;
  const std::uint64_t start = counters_.steps;
  while (!stop.load(std::memory_order_relaxed) && counters_.steps < end_steps)
    (void)WaitAndPollLockStep(50);
  return counters_.steps - start;
}

void SimulatedRobot::RunBusThread(const std::atomic<bool>& stop, const BusThreadConfig& bus) noexcept {
  if (bus.setup) bus.setup();
  std::array<pollfd, hal::kMaxBuses> fds{};
  nfds_t n = 0;
  for (const auto& c : channels_)
    if (c->poll_fd() >= 0) fds[n++] = {c->poll_fd(), POLLIN, 0};
  // at least every millisecond: the boards' own timers (the set-point watchdog, heartbeats) run
  // when nothing arrives, e.g. after the master died
  constexpr int kTimeoutMs = 1;
  std::uint64_t seen = 0;
  std::int64_t last = MonotonicNs();
  while (!stop.load(std::memory_order_relaxed)) {
    if (n > 0) {
      if (poll(fds.data(), n, kTimeoutMs) < 0 && errno != EINTR) break;
    } else {
      const timespec ms{0, 1'000'000};
      nanosleep(&ms, nullptr);
    }
    const std::int64_t now = MonotonicNs();
    bus_gap_.Add(now - last);
    // the newest sensor values the stepping thread handed over, the faults due (at their
    // simulated time), the answers. The boards are hardware: their clocks (heartbeats, the
    // set-point watchdog) are the wall clock, as the master's is. On the simulated time, a
    // stepping thread catching up after a stall of its core (up to kMaxCatchUp steps at once)
    // moved them 9 ms in 0.3 ms, and a board whose last set-point came just before tripped on a
    // master that had never been late (seen in a 60 s real-time run)
    SensorFrame f;
    bool fresh = false;
    while (sensor_frames_.TryPop(&f)) fresh = true;
    if (fresh) SetEmulatorSensors(f);
    ApplyFaults(1e-9 * static_cast<double>(sim_now_ns_.load(std::memory_order_relaxed)));
    Poll(MonotonicNs());
    SetpointFrame out;
    for (int j = 0; j < dynamics::kNumJoints; ++j) {
      const auto i = static_cast<std::size_t>(j);
      out.tau[i] = emulator_->torque_setpoint_Nm(j);
      out.enabled[i] = emulator_->outputs_enabled(j);
    }
    (void)setpoint_frames_.TryPush(out);  // full: the stepping thread is stalled; the next one
    last = MonotonicNs();
    bus_poll_time_.Add(last - now);
    // a SYNC answered while the step that was due is more than a period late: the answer is
    // the latest state there is, the physics stood still meanwhile
    const std::uint64_t new_syncs = NoteNewSyncs(now, &seen);
    if (new_syncs > 0 && now - step_due_ns_.load(std::memory_order_relaxed) > period_ns_)
      counters_.stale_answers += new_syncs;
  }
}

std::uint64_t SimulatedRobot::NoteNewSyncs(std::int64_t now_ns, std::uint64_t* seen) noexcept {
  std::uint64_t syncs = 0;
  for (std::size_t b = 0; b < channels_.size(); ++b) syncs = std::max(syncs, counters_.syncs[b]);
  const std::uint64_t fresh = syncs > *seen ? syncs - *seen : 0;
  if (fresh > 0) last_sync_ns_.store(now_ns, std::memory_order_relaxed);
  *seen = syncs;
  return fresh;
}

std::uint64_t SimulatedRobot::RunRealTime(const std::atomic<bool>& stop, double duration_s,
                                          const BusThreadConfig& bus) {
  const int tfd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (tfd < 0) throw std::runtime_error("simulated robot: timerfd_create failed");
  // one-shot absolute deadlines, each set after the last step: the phase lock moves them
  const auto arm = [tfd](std::int64_t at_ns) {
    itimerspec its{};
    its.it_value = {static_cast<time_t>(at_ns / 1'000'000'000), static_cast<long>(at_ns % 1'000'000'000)};
    return timerfd_settime(tfd, TFD_TIMER_ABSTIME, &its, nullptr) == 0;
  };
  const std::int64_t t0 = MonotonicNs() + period_ns_;
  if (!arm(t0)) {
    close(tfd);
    throw std::runtime_error("simulated robot: timerfd_settime failed");
  }
  const SyncPhaseLock lock{.period_ns = period_ns_, .phase_ns = cfg_.sync_phase_ns};
  std::array<pollfd, hal::kMaxBuses + 1> fds{};
  nfds_t n = 0;
  fds[n++] = {tfd, POLLIN, 0};
  if (!bus.enabled)
    for (const auto& c : channels_)
      if (c->poll_fd() >= 0) fds[n++] = {c->poll_fd(), POLLIN, 0};
  step_due_ns_.store(t0, std::memory_order_relaxed);
  last_sync_ns_.store(0, std::memory_order_relaxed);
  // behind after a stall (of this host, not of the boards), the boards answer only the newest
  // SYNC: the master discards answers to older ones, and each costs a datagram per board
  emulator_->SetAnswerNewestSyncOnly(true);
  std::atomic<bool> bus_stop{false};
  std::thread bus_thread;
  if (bus.enabled) {
    bus_thread_owns_emulator_ = true;
    bus_thread = std::thread([&] { RunBusThread(bus_stop, bus); });
  }
  const auto end_steps = duration_s > 0
                             ? static_cast<std::uint64_t>(std::llround(duration_s * 1e9 / static_cast<double>(period_ns_)))
                             : UINT64_MAX;
  const std::uint64_t start = counters_.steps;
  std::int64_t due_ns = t0;  // when the next step is due
  std::uint64_t syncs_seen = 0;
  // without the bus thread, this thread answers: it notes when a new SYNC came, for the lock
  const auto poll_answering = [&](std::int64_t now) {
    Poll(now);
    (void)NoteNewSyncs(now, &syncs_seen);
  };
  while (!stop.load(std::memory_order_relaxed) && counters_.steps < end_steps) {
    // channels without an fd (loopback) are polled at least every period
    if (poll(fds.data(), n, n > 1 || bus.enabled ? 50 : 1) < 0 && errno != EINTR) break;
    if (!bus.enabled) poll_answering(MonotonicNs());  // answer SYNCs with the latest state
    std::uint64_t fired = 0;
    if (read(tfd, &fired, sizeof fired) != static_cast<ssize_t>(sizeof fired) || fired == 0) continue;
    // the periods due by now: a late wake catches up (at most kMaxCatchUp steps at once),
    // counted as overruns; the SYNCs that arrive meanwhile are answered between the steps, with
    // the latest state
    const std::int64_t woke = MonotonicNs();
    const auto due = static_cast<std::uint64_t>(std::max<std::int64_t>(woke - due_ns, 0) / period_ns_) + 1;
    counters_.realtime_overruns += due - 1;
    const std::uint64_t steps = std::min<std::uint64_t>({due, kMaxCatchUp, end_steps - counters_.steps});
    for (std::uint64_t i = 0; i < steps; ++i) {
      const std::int64_t begin = MonotonicNs();
      step_lateness_.Add(begin - due_ns);
      if (begin - due_ns > period_ns_) ++counters_.late_steps;
      const std::int64_t sync = last_sync_ns_.load(std::memory_order_relaxed);
      if (lock.Active(sync, begin)) sync_phase_error_.Add(std::abs(lock.Error(begin, sync)));
      Step();
      const std::int64_t end = MonotonicNs();
      step_time_.Add(end - begin);
      if (!bus.enabled) poll_answering(end);
      due_ns += period_ns_;
    }
    if (due > steps) {  // periods given up: the simulated time falls behind
      counters_.dropped_steps += due - steps;
      due_ns += static_cast<std::int64_t>(due - steps) * period_ns_;
    }
    due_ns += lock.Correction(due_ns, last_sync_ns_.load(std::memory_order_relaxed), MonotonicNs());
    step_due_ns_.store(due_ns, std::memory_order_relaxed);
    if (!arm(due_ns)) break;
  }
  bus_stop.store(true, std::memory_order_relaxed);
  if (bus_thread.joinable()) bus_thread.join();
  bus_thread_owns_emulator_ = false;
  close(tfd);
  return counters_.steps - start;
}

}  // namespace hyq::sim
