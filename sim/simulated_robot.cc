#include "sim/simulated_robot.h"

#include <poll.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "dynamics/leg_kinematics.h"
#include "hal/clock.h"
#include "hal/config_error.h"
#include "hal/lockstep_channel.h"
#include "hal/protocol.h"
#include "sim/board_bus.h"

namespace hyq::sim {
namespace {

// HyQ resting with its base `height_m` above the lowest ground under its feet: the base level
// over the origin, each foot on the ground under its place in the standing posture (the floor,
// or the top of a box: PlantConfig::boxes), the legs' joints by their inverse kinematics from the
// standing angles
dynamics::VectorQ RestingQ(const dynamics::Model& model, const Plant& plant, double height_m) {
  const dynamics::LegKinematics legs(model);
  std::array<Eigen::Vector3d, dynamics::kNumFeet> p_BF_B;
  std::array<double, dynamics::kNumFeet> ground_m{};
  for (int leg = 0; leg < dynamics::kNumFeet; ++leg) {
    const auto i = static_cast<std::size_t>(leg);
    p_BF_B[i] = legs.Foot(leg, model.q_standing.segment<dynamics::kJointsPerLeg>(3 * leg));
    ground_m[i] = plant.GroundHeightAt(p_BF_B[i].x(), p_BF_B[i].y());  // the base over the origin
  }
  const double base_z = height_m + *std::min_element(ground_m.begin(), ground_m.end());
  dynamics::VectorQ q = model.StandingQ();
  q(2) = base_z;
  dynamics::IkStatus status = dynamics::IkStatus::kOk;
  for (int leg = 0; leg < dynamics::kNumFeet; ++leg) {
    const auto i = static_cast<std::size_t>(leg);
    const Eigen::Vector3d q_leg = model.q_standing.segment<dynamics::kJointsPerLeg>(3 * leg);
    dynamics::FootMotion foot;
    foot.p_BF_B = p_BF_B[i];
    foot.p_BF_B.z() = ground_m[i] + model.feet[leg].radius_m - base_z;
    dynamics::LegJointMotion j;
    const dynamics::IkStatus st = legs.Solve(leg, foot, q_leg, &j);
    if (st != dynamics::IkStatus::kOk && status == dynamics::IkStatus::kOk) status = st;
    q.segment<dynamics::kJointsPerLeg>(7 + 3 * leg) = j.q;
  }
  if (status != dynamics::IkStatus::kOk)
    throw hal::ConfigError("simulated robot: start height " + std::to_string(height_m) +
                           " m: expected a height the legs reach with the feet on the ground, found " +
                           dynamics::ToString(status));
  return q;
}

// The start posture: RestingQ at start_height_m; at 0, the standing posture, on the floor as the
// model gives it or, with a foot over a box, RestingQ at the standing base height
dynamics::VectorQ StartQ(const dynamics::Model& model, const Plant& plant, double start_height_m) {
  if (start_height_m > 0.0) return RestingQ(model, plant, start_height_m);
  const dynamics::LegKinematics legs(model);
  for (int leg = 0; leg < dynamics::kNumFeet; ++leg) {
    const Eigen::Vector3d p = legs.Foot(leg, model.q_standing.segment<dynamics::kJointsPerLeg>(3 * leg));
    if (plant.GroundHeightAt(p.x(), p.y()) > 0.0)
      return RestingQ(model, plant, model.standing_base_height_m);
  }
  return model.StandingQ();
}

}  // namespace

/// The device side of one bus, counting the SYNCs that arrive (even those the emulator ignores,
/// e.g. while its bus is off), so that lock-step follows the master's SYNCs on the wire.
/// In lock-step it passes nothing on while a step is due, nor during a stall of the master
/// (its frames wait, as a stalled master would not have sent them yet): the emulator answers each bus in turn
/// within one Poll, so the master, once the last bus's answer to SYNC k−1 is out, may send its
/// cycle k (set-points and SYNC k) on a bus the same Poll has still to read; read then, that
/// SYNC would be answered with the state before step k−1 and those set-points would act in it,
/// by a race between the processes. Left on the wire, they are read after the step.
class SimulatedRobot::SyncCounter final : public hal::CanChannel {
 public:
  SyncCounter(hal::CanChannel* inner, const SimulatedRobot* robot) : inner_(inner), robot_(robot) {}
  hal::CanStatus Send(std::span<const hal::CanFrame> f, std::size_t* sent) noexcept override {
    return inner_->Send(f, sent);
  }
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override {
    if (robot_->stalling_ || (robot_->polling_lockstep_ && robot_->StepDue())) {
      *received = 0;
      return hal::CanStatus::kOk;
    }
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
  bool frames_pending() const noexcept override { return inner_->frames_pending(); }
  bool tells_pending() const noexcept override { return inner_->tells_pending(); }
  void SetWaiterSpinning(bool on) noexcept override { inner_->SetWaiterSpinning(on); }
  std::uint64_t syncs() const noexcept { return syncs_; }

 private:
  hal::CanChannel* inner_;
  const SimulatedRobot* robot_;
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
  const PlantProfile& p = cfg.profile;
  if (!(cfg.actuator_tau_s >= 0) || !(cfg.actuator_rate_limit_Nm_s >= 0) ||
      !(p.encoder_noise_rad >= 0) || !(p.load_cell_noise_Nm >= 0) || !(p.gyro_noise_rad_s >= 0) ||
      !(p.accel_noise_m_s2 >= 0))
    throw hal::ConfigError("simulated robot: time constants, rate limits and noise levels must be "
                           ">= 0");
  if (channels.size() != config.buses.size())
    throw hal::ConfigError("simulated robot: " + std::to_string(config.buses.size()) +
                           " buses configured but " + std::to_string(channels.size()) +
                           " CAN channels given");
  std::vector<hal::CanChannel*> wrapped;
  for (hal::CanChannel* c : channels) {
    if (c == nullptr) throw hal::ConfigError("simulated robot: a CAN channel is missing");
    channels_.push_back(std::make_unique<SyncCounter>(c, this));
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
    board_velocity_ = std::make_unique<BoardVelocity>(config.joints, config.timing.cycle_period_s,
                                                      cfg.profile.velocity_cutoff_hz);
  } catch (const std::invalid_argument& e) {
    throw hal::ConfigError(std::string("simulated robot: ") + e.what());
  }
  gyro_bias_ = cfg.gyro_bias_rad_s + cfg.profile.GyroBias();
  accel_bias_ = cfg.accel_bias_m_s2 + cfg.profile.AccelBias();
  q_hold_ = StartQ(model, *plant_, cfg.start_height_m);
  plant_->Reset(q_hold_, dynamics::VectorV::Zero());
  actuation_->Reset(q_hold_.tail<dynamics::kNumJoints>());
  board_velocity_->Reset(q_hold_.tail<dynamics::kNumJoints>());
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
    if (f.kind == FaultSpec::Kind::kStall) continue;  // the lock-step's (RunDueStall)
    std::uint8_t& st = fault_state_[i];
    if (st == 0 && t >= f.t_s) {
      const bool ends = f.kind == FaultSpec::Kind::kSilent || f.kind == FaultSpec::Kind::kBusOff;
      st = ends && f.duration_s > 0 ? 1 : 2;
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
        case FaultSpec::Kind::kReset: {
          // the boot time on the boards' clock (simulated time in lock-step, the wall clock
          // with the bus thread), from the emulator's last Poll
          const std::int64_t boot_ns = std::llround(f.duration_s * 1e9);
          if (f.joint == FaultSpec::kImuTarget) emulator_->ResetImu(boot_ns);
          else emulator_->ResetJointBoard(f.joint, boot_ns);
          break;
        }
        case FaultSpec::Kind::kStall: break;
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
  if (bus_ != nullptr) {
    bus_->TakeNewestSetpoints(&setpoints_);  // the newest the boards hold
  } else {
    ApplyFaults(time_s());
    setpoints_ = BoardSetpoints();
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
    actuation_->Step(u, setpoints_.enabled, q.tail<dynamics::kNumJoints>(),
                     v.tail<dynamics::kNumJoints>());
  }
  tau_applied_ = actuation_->applied_Nm();
  plant_->SetLockDamping(actuation_->lock_damping_Nms());
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
    const bool contact =
        z - plant_->GroundHeightAt(q(0), q(1)) < cfg_.fall_height_m || plant_->BodyDownOnGround();
    if (contact && !sat_down_) {
      contact_speed_m_s_ = -plant_->v()(2);
      contact_tilt_deg_ = std::acos(std::clamp(up, -1.0, 1.0)) * 180.0 / M_PI;
      const bool gentle = contact_speed_m_s_ <= cfg_.max_sit_speed_m_s && up > std::cos(M_PI / 6);
      (gentle ? sat_down_ : fell_) = true;
      (gentle ? sat_down_at_s_ : fell_at_s_) = time_s();
    } else if (sat_down_ && up < std::cos(M_PI / 4)) {
      fell_ = true;  // sat down, then tipped over
      fell_at_s_ = time_s();
    }
  }
  UpdateSensors();
  if (observer_) {
    const std::int64_t t0 = MonotonicNs();
    observer_(*this);
    lockstep_time_.observer_ns += MonotonicNs() - t0;
  }
}

void SimulatedRobot::UpdateSensors() noexcept {
  const dynamics::VectorQ q = plant_->q();
  const dynamics::VectorV v = plant_->v();
  const PlantProfile& p = cfg_.profile;
  SensorFrame f;
  dynamics::VectorJ q_encoder;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    double qj = q(7 + j);
    if (p.encoder_noise_rad > 0) qj += p.encoder_noise_rad * Gaussian();
    q_encoder(j) = qj;
    f.q[i] = qj;
    double tau = actuation_->measured_Nm()(j);  // the actuator's output plus the load-cell bias
    if (p.load_cell_noise_Nm > 0) tau += p.load_cell_noise_Nm * Gaussian();
    tau_measured_(j) = tau;
    f.tau[i] = tau;
  }
  // the joint velocity: the boards' own from the angles their encoders saw, or the plant's
  board_velocity_->Step(q_encoder);
  v_reported_ = p.joint_velocity == JointVelocity::kBoard ? board_velocity_->velocity_rad_s()
                                                          : dynamics::VectorJ(v.tail<dynamics::kNumJoints>());
  for (int j = 0; j < dynamics::kNumJoints; ++j) f.v[static_cast<std::size_t>(j)] = v_reported_(j);
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
  if (p.gyro_noise_rad_s > 0)
    for (int i = 0; i < 3; ++i) r.gyro_rad_s(i) += p.gyro_noise_rad_s * Gaussian();
  if (p.accel_noise_m_s2 > 0)
    for (int i = 0; i < 3; ++i) r.specific_force_m_s2(i) += p.accel_noise_m_s2 * Gaussian();
  imu_reported_ = r;
  f.gyro = {r.gyro_rad_s(0), r.gyro_rad_s(1), r.gyro_rad_s(2)};
  f.accel = {r.specific_force_m_s2(0), r.specific_force_m_s2(1), r.specific_force_m_s2(2)};
  if (bus_ != nullptr) {
    bus_->GiveSensors(f);
    return;
  }
  SetBoardSensors(f);
}

SetpointFrame SimulatedRobot::BoardSetpoints() const noexcept {
  SetpointFrame f;
  for (int j = 0; j < dynamics::kNumJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    f.tau[i] = emulator_->torque_setpoint_Nm(j);
    f.enabled[i] = emulator_->outputs_enabled(j);
  }
  return f;
}

int SimulatedRobot::channel_poll_fd(std::size_t b) const noexcept {
  return channels_[b]->poll_fd();
}

void SimulatedRobot::SetBoardSensors(const SensorFrame& f) noexcept {
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

std::uint64_t SimulatedRobot::StepTarget(std::uint64_t* lo) const noexcept {
  std::uint64_t l = UINT64_MAX, hi = 0;
  for (const auto& c : channels_) {
    l = std::min(l, c->syncs());
    hi = std::max(hi, c->syncs());
  }
  if (lo != nullptr) *lo = l;
  // every bus saw SYNC k; or a bus fell kMaxSyncLead behind (the master gave up on it)
  return std::max(l, hi > kMaxSyncLead ? hi - kMaxSyncLead : 0);
}

bool SimulatedRobot::StepDue() const noexcept { return SyncedSteps() < StepTarget(nullptr); }

// A stall of the master due now (FaultSpec::Kind::kStall), between two SYNCs: every SYNC seen so
// far has been answered and stepped, the master's next cycle is not read yet. The plant steps on
// for the stall's whole periods with what the boards hold; the boards' own timers run on the
// simulated time (Poll with nothing read), so a board trips as a real one does when no SYNC
// comes for timing.device_setpoint_timeout_s. Then every bus carries the plant's clock frame
// (hal::PlantClock), ahead of the answers to the master's next SYNC, so that the master knows
// of the periods it lost before it reads them.
int SimulatedRobot::RunDueStall() noexcept {
  int steps = 0;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    if (f.kind != FaultSpec::Kind::kStall || fault_state_[i] != 0 || time_s() + 1e-9 < f.t_s)
      continue;
    fault_state_[i] = 2;
    ++counters_.faults_injected;
    const std::int64_t n = std::max<std::int64_t>(
        1, std::llround(f.duration_s * 1e9 / static_cast<double>(period_ns_)));
    stalling_ = true;
    for (std::int64_t k = 0; k < n; ++k) {
      Poll(time_ns());
      Step();
    }
    stalling_ = false;
    steps += static_cast<int>(n);
    counters_.stalled_steps += static_cast<std::uint64_t>(n);
    hal::PlantClock c;
    c.steps = static_cast<std::uint32_t>(counters_.steps);
    c.stalled_steps = static_cast<std::uint32_t>(counters_.stalled_steps);
    const hal::CanFrame frame = hal::EncodePlantClock(c);
    for (const auto& channel : channels_) {
      std::size_t sent = 0;
      (void)channel->Send(std::span(&frame, 1), &sent);
    }
  }
  return steps;
}

int SimulatedRobot::PollLockStep() noexcept {
  int steps = RunDueStall();
  const std::int64_t t0 = MonotonicNs();
  polling_lockstep_ = true;
  Poll(time_ns());
  polling_lockstep_ = false;
  const std::int64_t t1 = MonotonicNs();
  lockstep_time_.bus_ns += t1 - t0;
  for (;;) {
    std::uint64_t lo = 0;
    if (SyncedSteps() >= StepTarget(&lo)) break;
    if (lo <= SyncedSteps()) ++counters_.lockstep_forced;
    Step();
    ++steps;
  }
  if (steps > 0) lockstep_time_.step_ns += MonotonicNs() - t1;  // the observer's share included
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
  const std::int64_t t0 = MonotonicNs();
  std::array<hal::CanChannel*, hal::kMaxBuses> spinnable{};
  std::size_t ns = 0;
  for (const auto& c : channels_)
    if (c->tells_pending()) spinnable[ns++] = c.get();
  // shared memory: look a while before sleeping (hal::SpinForFrames)
  if (ns == 0 || !hal::SpinForFrames(std::span(spinnable.data(), ns), hal::kLockstepSpinNs))
    (void)poll(fds.data(), n, timeout_ms);
  lockstep_time_.wait_ns += MonotonicNs() - t0;
  ++lockstep_time_.waits;
  return PollLockStep();
}

std::uint64_t SimulatedRobot::RunLockStep(const std::atomic<bool>& stop, double duration_s) {
  const auto end_steps = duration_s > 0
                             ? static_cast<std::uint64_t>(std::llround(duration_s * 1e9 / static_cast<double>(period_ns_)))
                             : UINT64_MAX;
  const std::uint64_t start = counters_.steps;
  std::int64_t t0 = MonotonicNs();
  std::uint64_t steps0 = start;
  while (!stop.load(std::memory_order_relaxed) && counters_.steps < end_steps) {
    const bool before_first = counters_.steps == start;
    (void)WaitAndPollLockStep(50);
    if (before_first && counters_.steps != start) {  // the split counts from here
      lockstep_time_ = LockstepTime{};
      t0 = MonotonicNs();
      steps0 = counters_.steps;
    }
  }
  lockstep_time_.loop_ns += MonotonicNs() - t0;
  lockstep_time_.steps += counters_.steps - steps0;
  return counters_.steps - start;
}

std::uint64_t SimulatedRobot::NoteNewSyncs(std::int64_t now_ns, std::uint64_t* seen) noexcept {
  std::uint64_t syncs = 0;
  for (std::size_t b = 0; b < channels_.size(); ++b) syncs = std::max(syncs, counters_.syncs[b]);
  const std::uint64_t fresh = syncs > *seen ? syncs - *seen : 0;
  if (fresh > 0) last_sync_ns_.store(now_ns, std::memory_order_relaxed);
  *seen = syncs;
  return fresh;
}

}  // namespace hyq::sim
