// A plant that is not the model: every way the simulated HyQ may differ from
// what the controller assumes, each switchable, in one struct shared by hyq-sim
// (SimulatedRobot) and the in-process experiment (RunExperiment). docs/simulation.md, "Plant
// profiles", lists every factor, its flag, its level in `realistic` and the source of the level.
//
//  - model error: payload and per-link mass / CoM / inertia errors (PlantConfig::model_error,
//    applied to the MuJoCo model; the controller keeps the nominal URDF)
//  - actuators: HyQ's hydraulics with the board's torque loop (sim/hydraulic_actuator.h)
//    instead of the first-order lag
//  - joint friction, Coulomb + viscous (PlantConfig::joint_friction)
//  - transport delay: a set-point takes effect k plant steps after it was given
//  - sensor biases: a load-cell offset per joint and IMU gyro / accelerometer biases, drawn
//    from the seed
//  - sensors (hyq-sim): Gaussian noise on the encoders, load cells and IMU, and the joint
//    velocity the boards compute from their encoders (sim/board_velocity.h) or the plant's exact
//    one
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dynamics/model.h"
#include "hal/calibration.h"
#include "sim/board_velocity.h"
#include "sim/hydraulic_actuator.h"
#include "sim/plant.h"

namespace hyq::sim {

inline constexpr int kMaxDelayCycles = 50;

/// The joint velocity the actuator boards report.
enum class JointVelocity : std::uint8_t {
  kBoard,  // from the encoder's counts, differenced and filtered (sim/board_velocity.h)
  kExact,  // the plant's velocity, rounded to 1 count/s
};
/// "board", "exact".
const char* ToString(JointVelocity v) noexcept;

struct PlantProfile {
  std::string name = "ideal";
  ModelErrorConfig model_error;          // payload_kg 0 and link_errors false: none
  JointFrictionConfig joint_friction;    // enabled false: none
  bool hydraulics = false;               // false: the caller's first-order lag (or ideal)
  HydraulicParams hydraulic;
  int delay_cycles = 0;                  // 0..kMaxDelayCycles
  /// A board with its outputs off closes its valve and locks its joint (the pump running);
  /// false: the pump is off and such a joint is free (an unpowered robot folding onto its stops).
  bool pump_on = true;
  /// Sensor biases, drawn once from bias_seed, uniform in ±level: per joint a load-cell offset
  /// (N·m at the joint), per IMU axis a gyro (rad/s) and an accelerometer (m/s²) bias.
  double load_cell_bias_Nm = 0.0;
  double gyro_bias_rad_s = 0.0;
  double accel_bias_m_s2 = 0.0;
  std::uint64_t bias_seed = 1;
  /// Sensor noise, Gaussian, σ per 1 ms sample (hyq-sim: SimulatedRobot draws it from its seed).
  double encoder_noise_rad = 0.0;    // added to the angle before the encoder's quantisation
  double load_cell_noise_Nm = 0.0;   // of the measured joint torque (load cell / HAA torque sensor)
  double gyro_noise_rad_s = 0.0;     // per axis
  double accel_noise_m_s2 = 0.0;     // per axis
  /// What the boards report as joint velocity (hyq-sim), and the cut-off of their low-pass.
  JointVelocity joint_velocity = JointVelocity::kBoard;
  double velocity_cutoff_hz = kBoardVelocityCutoffHz;

  /// Today's plant: nothing of the above (hyq-sim keeps its --actuator-tau lag).
  static PlantProfile Ideal();
  /// Every factor on at the levels of docs/simulation.md, sensor noise included.
  static PlantProfile Realistic();
  /// Copies the plant-side factors (model error, joint friction) into `pc`.
  void ApplyTo(PlantConfig* pc) const;
  /// The drawn biases.
  std::array<double, dynamics::kNumJoints> LoadCellBiases() const;
  Eigen::Vector3d GyroBias() const;
  Eigen::Vector3d AccelBias() const;
  /// One JSON object with every factor and its level (summaries, results.json).
  std::string Json() const;
};

/// "board" or "exact"; throws std::invalid_argument naming `what`, the names expected and what
/// was found.
JointVelocity JointVelocityByName(std::string_view name, const std::string& what);

/// "ideal" or "realistic"; throws std::invalid_argument naming `what`, the names expected and
/// what was found.
PlantProfile ProfileByName(std::string_view name, const std::string& what);

/// The actuation path from the set-points to the torque the plant applies, and the torque the
/// load cells report: delay (a ring of k + 1 slots), then per joint either the hydraulic
/// actuator with its torque loop, or the first-order lag of SimulatedRobot's eq. (1) with its
/// rate limit (lag_tau_s 0: ideal); the measured torque is the actuator's output at the end of
/// the step (the rod's load cell / the HAA's torque sensor) plus the load-cell bias.
/// A joint whose board has its outputs off applies nothing and is hydraulically locked: the
/// hydraulics close its valve; without them, lock_damping_Nms() gives the locked joint's
/// resistance (HydraulicActuator::LockDamping, from the HAL's calibrations; 0 without them),
/// lowered at speed so that it never asks for more than the relief valve's torque.
/// Step() allocates nothing and never throws.
class Actuation {
 public:
  /// joints: the HAL's calibrations (12; needed when profile.hydraulics). Throws at
  /// configuration time (bad delay, missing calibration, bad hydraulic parameters).
  Actuation(const dynamics::Model& model, std::span<const hal::JointCalibration> joints,
            const PlantProfile& profile, double lag_tau_s, double rate_limit_Nm_s, double step_s);
  ~Actuation();

  /// At rest at the joint angles q with zero torque; the delay line emptied.
  void Reset(const dynamics::VectorJ& q) noexcept;
  /// One plant step: u the set-points (already clamped), q and qd the joints at the step's start.
  /// on: whether each board's outputs are on (they pass the delay line with the set-points).
  void Step(const dynamics::VectorJ& u, const std::array<bool, dynamics::kNumJoints>& on,
            const dynamics::VectorJ& q, const dynamics::VectorJ& qd) noexcept;
  void Step(const dynamics::VectorJ& u, const dynamics::VectorJ& q, const dynamics::VectorJ& qd) noexcept {
    std::array<bool, dynamics::kNumJoints> on;
    on.fill(true);
    Step(u, on, q, qd);
  }
  /// Per joint, the locked joint's damping this step (N·m·s/rad; 0 when its outputs are on or
  /// the hydraulics model the lock themselves): the plant applies it implicitly (Plant::SetLockDamping).
  const dynamics::VectorJ& lock_damping_Nms() const noexcept { return lock_; }
  /// What the plant applies this step (the mean over the step for the hydraulics).
  const dynamics::VectorJ& applied_Nm() const noexcept { return applied_; }
  /// The actuator's torque at the end of the step plus the load-cell bias (noise is the caller's).
  const dynamics::VectorJ& measured_Nm() const noexcept { return measured_; }
  const HydraulicActuator* hydraulic(int joint) const noexcept;

 private:
  PlantProfile profile_;
  double alpha_, rate_step_Nm_;
  bool passthrough_;  // no lag, no rate limit: the set-point itself
  std::array<dynamics::VectorJ, kMaxDelayCycles + 1> ring_{};
  std::array<std::array<bool, dynamics::kNumJoints>, kMaxDelayCycles + 1> on_ring_{};
  int head_ = 0;
  std::array<double, dynamics::kNumJoints> bias_{};
  std::array<std::unique_ptr<HydraulicActuator>, dynamics::kNumJoints> hyd_;  // with calibrations
  dynamics::VectorJ lock_ = dynamics::VectorJ::Zero();
  dynamics::VectorJ applied_ = dynamics::VectorJ::Zero();
  dynamics::VectorJ measured_ = dynamics::VectorJ::Zero();
};

}  // namespace hyq::sim
