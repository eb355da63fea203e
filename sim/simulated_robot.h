// The simulated HyQ: the MuJoCo plant (sim/plant.h) behind HyQ's devices (the HAL's device
// Emulator) on any CAN channels, so that the unmodified servo daemon drives it like the real
// robot (docs/simulation.md). This class is the physics, the sensors, the injected faults, fall
// detection and the lock-step; real time, the boards answer from a thread of their own
// (sim/board_bus.h) and the steps follow the clock and the master's SYNC (sim/realtime_runner.h).
//
// Models, per 1 ms step h:
//  - actuator j (sim/plant_profile.h, Actuation; with the `realistic` profile HyQ's
//    hydraulics and torque loop instead, after a transport delay): the board's set-point u
//    (a board whose outputs are off applies none: its closed valve locks the joint, see
//    Actuation) is clamped to the joint's torque limit, then the applied
//    torque follows a first-order lag with time constant T, discretised exactly for a set-point
//    held over the step (zero-order hold):
//      tau[k+1] = tau[k] + (1 - exp(-h / T)) (u[k] - tau[k])                    (1)
//    (T = 0: tau = u), optionally limited in rate: |tau[k+1] - tau[k]| <= rmax h.
//  - encoders: the emulator reports counts through the HAL calibration, c = c0 + round(d q N/2pi),
//    i.e. quantised to one encoder count (2 pi / 131072 = 47.9 urad with the default YAML).
//    Optional Gaussian noise (rad) is added before the quantisation.
//  - joint velocity (PlantProfile::joint_velocity): by default what the board computes from
//    those counts, their difference over the step through a first-order low-pass
//    (sim/board_velocity.h); `exact`: the plant's velocity. Reported to 1 count/s.
//  - load cells / torque sensors: the actuator's torque plus Gaussian noise N(0, s^2)
//    (N·m at the joint), reported as the sensor counts for that torque at the current angle.
//  - IMU at model.imu (upside down on the trunk): MuJoCo's gyro and accelerometer at that site
//    (angular velocity and specific force in the IMU frame, from cacc of mj_rnePostConstraint,
//    i.e. including the contact forces of the step) plus bias and Gaussian noise.
//  - hold: until every actuator board has its outputs enabled, the robot is held at its standing
//    posture (the state is reset every step, as on its stand); the IMU reads rest.
//  - faults at simulated times (FaultSpec, sim/fault_spec.h): silent board, corrupt /
//    dropped TPDOs, broken sensor, bus-off, EMCY, a board's reset; in lock-step, a stall of the
//    master (the plant steps on without its SYNCs, then tells it the periods it lost).
//
// Lock-step (deterministic): PollLockStep() drains the channels through the emulator at simulated
// time; the emulator answers each SYNC with the current state; when the SYNC of cycle k has been
// received on every bus, the latest set-points go through (1) and the plant steps once; once a
// step is due, nothing more is read from any bus until it has been taken. A bus
// whose SYNCs stop while another is kMaxSyncLead SYNCs ahead no longer holds the others back.
// Real time: Poll(now) answers SYNCs with the latest state, Step() advances the physics; the
// caller (RealtimeRunner) steps on absolute CLOCK_MONOTONIC deadlines.
//
// Poll, PollLockStep and Step do not allocate (tests/hil/simulated_robot_test.cc, NoHeap).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "dynamics/model.h"
#include "hal/can_channel.h"
#include "hal/emulator.h"
#include "hal/hal_config.h"
#include "sim/board_velocity.h"
#include "sim/fault_spec.h"
#include "sim/plant.h"
#include "sim/plant_profile.h"

namespace hyq::sim {

struct SimulatedRobotConfig {
  /// timestep_s is taken from the HAL's cycle period; the ground (ground_mu, foot_mu, patches,
  /// boxes) is used as given
  PlantConfig plant;
  /// How the plant differs from the model: model error, hydraulic actuators instead of eq. (1),
  /// joint friction, delay, sensor biases, sensor noise, and how the boards make the joint
  /// velocity. Default: ideal (none of them; the boards' velocity).
  PlantProfile profile;
  double actuator_tau_s = 0.005;          // T of eq. (1); 0 = ideal actuator; unused with hydraulics
  double actuator_rate_limit_Nm_s = 0.0;  // 0 = none
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();     // IMU frame
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();     // IMU frame
  bool hold = true;                       // hold at the start posture until all enabled
  /// The start posture: base height with the feet on the ground under their standing places
  /// (0: standing). Default: HyQ's resting crouch, from which the daemon stands it up. With
  /// boxes (plant.boxes) under feet, each foot rests on the ground under it (the box's top) and the
  /// height is above the lowest of them: on a platform under all four feet, above the platform.
  double start_height_m = 0.40;
  std::uint64_t seed = 1;                 // sensor noise (the profile's σ) and the emulator's random drops
  /// Ground contact: the trunk or a leg (not a foot) touches the floor, the trunk or an upper leg
  /// touches a box (Plant::BodyDownOnGround: a shin grazing a box's edge is not one), or the base
  /// is below this height above the ground under it (the floor or a box's top). It is a sit-down when the base comes down no faster than max_sit_speed_m_s
  /// and the trunk is upright (tilt < 30°), a fall otherwise; after a sit-down, a tilt past 45°
  /// is still a fall.
  double fall_height_m = 0.2;  // the trunk within 0.1 m of the ground
  double max_sit_speed_m_s = 0.5;
  /// Real time (RealtimeRunner): a physics step begins this long after the master's SYNC
  /// (SyncPhaseLock, sim/sync_phase_lock.h), so that each set-point acts from the next step, as
  /// in lock-step; < 0: the steps run free of the SYNC, at the phase the start gave.
  std::int64_t sync_phase_ns = 500'000;
};

struct SimulatedRobotCounters {
  std::uint64_t steps = 0;
  std::uint64_t held_steps = 0;
  std::uint64_t lockstep_forced = 0;     // steps taken because one bus fell kMaxSyncLead behind
  std::uint64_t faults_injected = 0;
  std::uint64_t stalled_steps = 0;       // steps taken while the master stalled (FaultSpec kStall)
  std::array<std::uint64_t, hal::kMaxBuses> syncs{};  // per bus, seen on the wire
};

/// Where lock-step's wall time goes (WaitAndPollLockStep, PollLockStep): waiting in poll() for
/// the master (its cycle and the transport's hand-off), the bus work (draining the channels, the
/// boards' answers), the physics step (actuators, plant, sensors) and the step observer (truth
/// recording, progress); from the first step on (not the wait for the master to start).
struct LockstepTime {
  std::uint64_t steps = 0;
  std::int64_t loop_ns = 0;  // RunLockStep's, from the first step
  std::int64_t wait_ns = 0, bus_ns = 0, step_ns = 0, observer_ns = 0;
  std::uint64_t waits = 0;  // poll() calls
};

/// What a step hands HyQ's boards (their sensor values) and what it takes back (their
/// set-points); real time, across threads (sim/board_bus.h).
struct SensorFrame {
  std::array<double, dynamics::kNumJoints> q{}, v{}, tau{};
  std::array<double, 3> gyro{}, accel{};
};
struct SetpointFrame {
  std::array<double, dynamics::kNumJoints> tau{};
  std::array<bool, dynamics::kNumJoints> enabled{};
};

class BoardBus;

class SimulatedRobot {
 public:
  static constexpr std::uint64_t kMaxSyncLead = 3;

  /// channels[i] carries config.buses[i] (the device side); not owned, must outlive this.
  /// Throws (ConfigError, PlantError) at configuration time.
  SimulatedRobot(const dynamics::Model& model, const hal::HalConfig& config,
                 std::span<hal::CanChannel* const> channels, const SimulatedRobotConfig& cfg);
  ~SimulatedRobot();
  SimulatedRobot(const SimulatedRobot&) = delete;
  SimulatedRobot& operator=(const SimulatedRobot&) = delete;

  /// At f.t_s of simulated time. A stall of the master (kStall) happens only in lock-step
  /// (PollLockStep); real time has no such fault here (a stalled daemon is the daemon's own).
  void ScheduleFault(const FaultSpec& f);
  /// Called at the end of every Step (truth recording, progress); set before running.
  void SetStepObserver(std::function<void(const SimulatedRobot&)> observer) {
    observer_ = std::move(observer);
  }

  // --- lock-step ------------------------------------------------------------------------------
  /// Drains every channel (Emulator::Poll at the simulated time) and steps the physics once per
  /// SYNC seen on every bus; first, a stall of the master that is due (FaultSpec kStall: its
  /// steps, then the plant's clock frame on every bus). Returns the steps taken. Never blocks.
  int PollLockStep() noexcept;
  /// Blocks in poll() on the channels' fds (at most timeout_ms) until something arrives, then
  /// PollLockStep(). Returns the steps taken (0 on timeout). Channels without an fd: no wait.
  int WaitAndPollLockStep(int timeout_ms) noexcept;

  /// Lock-step until `stop` or `duration_s` of simulated time (0: until stop).
  std::uint64_t RunLockStep(const std::atomic<bool>& stop, double duration_s);

  // --- the boards, for whichever thread answers them -----------------------------------------
  /// Answers whatever arrived (Emulator::Poll(now_ns)); SYNCs are counted, nothing steps.
  /// Not while a BoardBus runs (it owns the emulator then).
  void Poll(std::int64_t now_ns) noexcept;
  /// One physics step with the latest set-points (actuator model, plant, sensors, faults).
  void Step() noexcept;
  /// The faults due at simulated time t_s (the stepping thread's own before each step, or the
  /// bus thread's).
  void ApplyFaults(double t_s) noexcept;
  /// The boards' sensor values (encoders, load cells, IMU).
  void SetBoardSensors(const SensorFrame& f) noexcept;
  /// The boards' set-points and whether their outputs are enabled.
  SetpointFrame BoardSetpoints() const noexcept;
  /// Real time, on the thread that answers: the SYNCs seen since *seen (the most on any bus);
  /// when there are any, `now_ns` becomes the newest SYNC's time (last_sync_ns(), the phase
  /// lock's reference).
  std::uint64_t NoteNewSyncs(std::int64_t now_ns, std::uint64_t* seen) noexcept;
  std::int64_t last_sync_ns() const noexcept { return last_sync_ns_.load(std::memory_order_relaxed); }
  void ForgetLastSync() noexcept { last_sync_ns_.store(0, std::memory_order_relaxed); }
  /// Simulated time, for another thread.
  std::int64_t published_time_ns() const noexcept { return sim_now_ns_.load(std::memory_order_relaxed); }
  /// The boards go to `bus` (its thread answers them; a step then takes their set-points from
  /// it and hands it the sensor values), or back to the stepping thread (nullptr). Only while
  /// no step runs.
  void ConnectBoardBus(BoardBus* bus) noexcept { bus_ = bus; }
  /// The fd to poll for bus b's frames (−1: none, e.g. the in-process loopback).
  int channel_poll_fd(std::size_t b) const noexcept;
  std::int64_t period_ns() const noexcept { return period_ns_; }
  const SimulatedRobotConfig& config() const noexcept { return cfg_; }

  // --- state ----------------------------------------------------------------------------------
  double time_s() const noexcept;  // simulated: steps x period
  std::int64_t time_ns() const noexcept { return static_cast<std::int64_t>(counters_.steps) * period_ns_; }
  bool holding() const noexcept { return holding_; }
  /// The largest downward speed of the base since the release, m/s.
  double max_descent_speed_m_s() const noexcept { return max_descent_m_s_; }
  bool fell() const noexcept { return fell_; }
  double fell_at_s() const noexcept { return fell_at_s_; }
  /// The first ground contact was slow and upright (SimulatedRobotConfig::fall_height_m).
  bool sat_down() const noexcept { return sat_down_; }
  double sat_down_at_s() const noexcept { return sat_down_at_s_; }
  /// The base's downward speed at the first ground contact (fall or sit-down), m/s.
  double contact_speed_m_s() const noexcept { return contact_speed_m_s_; }
  /// The trunk's tilt from upright when it first touched the ground (deg).
  double contact_tilt_deg() const noexcept { return contact_tilt_deg_; }
  double min_base_height_m() const noexcept { return min_base_height_m_; }
  /// The IMU's biases (the configured plus the profile's drawn ones), in the trunk's frame.
  Eigen::Vector3d gyro_bias_B() const noexcept { return R_BF_ * gyro_bias_; }
  Eigen::Vector3d accel_bias_B() const noexcept { return R_BF_ * accel_bias_; }
  const dynamics::VectorJ& applied_torque_Nm() const noexcept { return tau_applied_; }
  const dynamics::VectorJ& measured_torque_Nm() const noexcept { return tau_measured_; }
  const ImuReading& imu_reported() const noexcept { return imu_reported_; }
  const SimulatedRobotCounters& counters() const noexcept { return counters_; }
  const LockstepTime& lockstep_time() const noexcept { return lockstep_time_; }
  const std::vector<FaultSpec>& faults() const noexcept { return faults_; }
  Plant& plant() noexcept { return *plant_; }
  const Plant& plant() const noexcept { return *plant_; }
  const Actuation& actuation() const noexcept { return *actuation_; }
  /// The velocity the boards computed at the last step (PlantProfile::joint_velocity board).
  const BoardVelocity& board_velocity() const noexcept { return *board_velocity_; }
  /// The joint velocity reported at the last step (the board's, or the plant's exact one).
  const dynamics::VectorJ& reported_velocity_rad_s() const noexcept { return v_reported_; }
  hal::Emulator& emulator() noexcept { return *emulator_; }
  std::size_t num_buses() const noexcept { return channels_.size(); }

 private:
  class SyncCounter;
  /// The steps the SYNCs seen so far call for; *lo (if given): the fewest SYNCs of any bus.
  /// They are counted against SyncedSteps(): a stall's steps answer no SYNC.
  std::uint64_t StepTarget(std::uint64_t* lo) const noexcept;
  /// A step is due (StepTarget above the steps taken).
  bool StepDue() const noexcept;
  std::uint64_t SyncedSteps() const noexcept { return counters_.steps - counters_.stalled_steps; }
  /// Lock-step: the master's stall due now, if any (FaultSpec kStall); returns the steps taken.
  int RunDueStall() noexcept;
  void UpdateSensors() noexcept;
  double Gaussian() noexcept;

  const dynamics::Model& model_;
  hal::HalConfig config_;
  SimulatedRobotConfig cfg_;
  std::int64_t period_ns_;
  std::vector<std::unique_ptr<SyncCounter>> channels_;
  std::unique_ptr<Plant> plant_;
  std::unique_ptr<Actuation> actuation_;
  std::unique_ptr<BoardVelocity> board_velocity_;  // the boards' velocity from their encoders
  Eigen::Vector3d gyro_bias_, accel_bias_;  // the config's plus the profile's
  std::unique_ptr<hal::Emulator> emulator_;
  BoardBus* bus_ = nullptr;  // real time: the boards' own thread, when it runs
  bool polling_lockstep_ = false;  // inside PollLockStep's Poll: SyncCounter holds frames back
  bool stalling_ = false;          // inside a stall of the master: SyncCounter holds frames back
  SetpointFrame setpoints_;  // the stepping thread's newest
  std::atomic<std::int64_t> sim_now_ns_{0};   // simulated time, for the bus thread's faults
  std::atomic<std::int64_t> last_sync_ns_{0};  // real time: when the newest SYNC was seen
  dynamics::VectorQ q_hold_;
  dynamics::VectorJ tau_applied_ = dynamics::VectorJ::Zero();
  dynamics::VectorJ tau_measured_ = dynamics::VectorJ::Zero();
  dynamics::VectorJ v_reported_ = dynamics::VectorJ::Zero();
  ImuReading imu_reported_;
  Eigen::Matrix3d R_BF_;  // IMU in the trunk
  std::vector<FaultSpec> faults_;
  std::vector<std::uint8_t> fault_state_;  // 0 pending, 1 active, 2 done
  SimulatedRobotCounters counters_;
  LockstepTime lockstep_time_;
  bool holding_;
  double max_descent_m_s_ = 0.0;
  bool fell_ = false;
  double fell_at_s_ = 0.0;
  bool sat_down_ = false;
  double sat_down_at_s_ = 0.0;
  double contact_speed_m_s_ = 0.0;
  double contact_tilt_deg_ = 0.0;
  std::function<void(const SimulatedRobot&)> observer_;
  double min_base_height_m_;
  std::uint64_t rng_;
  double spare_gaussian_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace hyq::sim
