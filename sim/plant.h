// Simulated HyQ: a MuJoCo (2.2.2) model generated from the project's own model, with contact
// that behaves like Coulomb friction (docs/simulation.md), torque actuators with HyQ's limits,
// ground friction per run and per foot ("one foot on ice, three on rubber"), steps (boxes) on
// the floor. Used by
// hyq-experiment and, through the device emulator, by the hardware-in-the-loop simulator.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dynamics/model.h"

struct mjModel_;
struct mjData_;

namespace hyq::sim {

/// A rectangle of the ground with a friction of its own (e.g. an icy patch), world x-y, m.
/// Where patches overlap, the first one listed wins.
struct GroundPatch {
  double x0_m = 0.0, x1_m = 0.0, y0_m = 0.0, y1_m = 0.0;
  double mu = 1.0;
  bool Contains(double x, double y) const noexcept {
    return x >= x0_m && x <= x1_m && y >= y0_m && y <= y1_m;
  }
};

/// A step: an axis-aligned box resting on the floor, its top height_m above the floor over the
/// world x-y rectangle [x0_m, x1_m] × [y0_m, y1_m]. Its top and sides are ground like the floor:
/// the feet touch it with their friction (PlantConfig::foot_mu, the patches), the trunk and the
/// legs collide with it. A step up of h is a box of height h where a foot lands; a step down of h
/// is a platform of height h the robot stands on and walks off (a box larger than its feet's
/// rectangle, about 1.0 × 0.8 m for HyQ's stance). Where boxes overlap, the highest is the ground.
struct GroundBox {
  double x0_m = 0.0, x1_m = 0.0, y0_m = 0.0, y1_m = 0.0;
  double height_m = 0.0;
  bool Contains(double x, double y) const noexcept {
    return x >= x0_m && x <= x1_m && y >= y0_m && y <= y1_m;
  }
};

/// The ground's height at world (x, y): the highest box whose rectangle holds the point, else 0
/// (the floor). Evaluated at a foot's sphere centre it is the surface that foot stands on, away
/// from a box's edges.
double GroundHeight(const std::vector<GroundBox>& boxes, double x, double y) noexcept;

/// Model error: the plant's bodies differ from the model the controller uses.
struct ModelErrorConfig {
  /// A rigid point mass fixed to the trunk (kg; position in the trunk frame, m), lumped into the
  /// trunk's inertia (parallel axis). 0 kg: none.
  double payload_kg = 0.0;
  Eigen::Vector3d p_BoP_B = Eigen::Vector3d::Zero();
  /// Per-body errors, drawn uniformly from `seed` for every body (trunk and 12 links):
  /// mass × (1 + U(−m, m)), each CoM coordinate + U(−c, c), rotational inertia × (1 + U(−i, i)).
  bool link_errors = false;
  std::uint64_t seed = 1;
  double mass_rel = 0.05;
  double com_m = 0.01;
  double inertia_rel = 0.10;
};

/// The model with these errors applied (what the plant is built from; the controller keeps the
/// nominal one). Deterministic in the seed on every platform (xorshift64*).
dynamics::Model PerturbModel(const dynamics::Model& nominal, const ModelErrorConfig& e);

/// Joint friction applied by the plant, per joint type (haa, hfe, kfe):
///   τ_f = −(τ_c tanh(q̇ / v_s) + b q̇)   (Coulomb smoothed over |q̇| ≲ v_s, plus viscous)
struct JointFrictionConfig {
  bool enabled = false;
  std::array<double, 3> coulomb_Nm{0.0, 0.0, 0.0};
  std::array<double, 3> viscous_Nm_s{0.0, 0.0, 0.0};
  double band_rad_s = 0.01;
  double Torque(int joint, double qd_rad_s) const noexcept;
};

struct PlantConfig {
  double timestep_s = 1e-3;
  double ground_mu = 1.0;
  /// Per-foot friction (lf, rf, lh, rh); negative: the ground's.
  std::array<double, 4> foot_mu{-1.0, -1.0, -1.0, -1.0};
  /// Friction patches: a foot whose sphere centre is above a patch (x-y) has the patch's μ, at
  /// every step; elsewhere the foot's own (foot_mu) or the ground's.
  std::vector<GroundPatch> patches;
  /// Steps on the floor. None: the model is the floor alone (no extra geoms or contact pairs).
  /// Each needs x0 < x1, y0 < y1 and a finite height > 0 (the constructor throws otherwise).
  std::vector<GroundBox> boxes;
  /// Adds MuJoCo's gyro and accelerometer at the IMU site (model.imu) for Plant::Imu(). Costs
  /// mj_rnePostConstraint per step (MuJoCo runs it for acceleration sensors); off by default.
  bool imu_sensor = false;
  ModelErrorConfig model_error;       // the MuJoCo model is built from PerturbModel(model, this)
  JointFrictionConfig joint_friction;
};

/// What an ideal IMU at model.imu measures, in the IMU frame F: angular velocity w_WF_F and
/// specific force (acceleration minus gravity) f_F.
struct ImuReading {
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d specific_force_m_s2 = Eigen::Vector3d::Zero();
};

/// Contact force on one foot from the ground (the floor and the boxes), world frame, N.
struct FootContact {
  bool touching = false;
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();
  /// Tangential velocity of the foot's material point at its contact (at the contact that carries
  /// the most normal force, when the foot touches two surfaces at a box's edge).
  Eigen::Vector3d slip_velocity_W = Eigen::Vector3d::Zero();
};

/// Thrown at configuration time when MuJoCo rejects the generated model.
class PlantError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Plant {
 public:
  Plant(const dynamics::Model& model, const PlantConfig& config);
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  /// State in the project's convention (docs/conventions.md; MuJoCo's qpos/qvel).
  void Reset(const dynamics::VectorQ& q, const dynamics::VectorV& v);
  /// One step with these joint torques (clamped to the actuators' ±effort limit), plus the joint
  /// friction (PlantConfig::joint_friction) at the velocity the step starts from.
  void Step(const dynamics::VectorJ& tau_Nm);
  /// Per joint, a damping (N·m·s/rad) for the next steps: a joint locked by its closed valve
  /// (Actuation::lock_damping_Nms). MuJoCo's Euler integrator takes joint damping implicitly, so
  /// a stiff lock stays stable at 1 ms. 0: none.
  void SetLockDamping(const dynamics::VectorJ& b_Nms_rad) noexcept;

  dynamics::VectorQ q() const;
  dynamics::VectorV v() const;
  double time() const;
  /// Per-foot contact with the ground at the current state.
  std::array<FootContact, 4> FootContacts() const;
  /// The IMU at the state the last Step started from (MuJoCo's sensor stage runs before the
  /// integration; after Reset: the reset state). Zero unless PlantConfig::imu_sensor.
  ImuReading Imu() const;
  /// Whether any geom other than the feet (trunk, legs) touches the ground (the floor or a box).
  bool BodyTouchesGround() const;
  /// Whether the robot is down on the ground: the trunk or a leg touches the floor, or the trunk
  /// or an upper leg touches a box. A lower leg (the link that carries the foot) touching a box
  /// is not: stepping past a box's edge, the shin grazes it with the robot walking upright.
  bool BodyDownOnGround() const;
  /// The ground's height at world (x, y): GroundHeight over PlantConfig::boxes.
  double GroundHeightAt(double x, double y) const noexcept { return GroundHeight(boxes_, x, y); }
  const std::vector<GroundBox>& boxes() const noexcept { return boxes_; }
  /// The foot's friction coefficient with the ground away from the patches (changes take
  /// effect at the next step).
  void SetFootFriction(int foot, double mu);
  /// The friction coefficient the foot has now: its patch's, or the one SetFootFriction set.
  double foot_friction(int foot) const;
  /// The ground's friction at world (x, y) for this foot: the first patch there, else the
  /// foot's own (the experiment's oracle μ).
  double FrictionAt(int foot, double x, double y) const;

  /// The generated MJCF (for inspection and for MuJoCo's own tools).
  const std::string& mjcf() const { return mjcf_; }
  const mjModel_* mj_model() const { return m_; }
  mjData_* mj_data() { return d_; }

 private:
  std::string mjcf_;
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::array<int, 4> foot_geom_{}, foot_body_{};
  /// Each foot's contact pairs with the ground: the floor's first, then one per box.
  std::array<std::vector<int>, 4> foot_pairs_;
  std::array<double, 4> base_mu_{};
  std::vector<GroundPatch> patches_;
  std::vector<GroundBox> boxes_;
  JointFrictionConfig friction_;
  void ApplyPatches();
  void SetPairFriction(int foot, double mu);
  /// The floor and the boxes are the world body's geoms.
  bool IsGround(int geom) const noexcept;
  bool IsFoot(int geom) const noexcept;
  int floor_geom_ = -1;
  int gyro_adr_ = -1, accel_adr_ = -1;
};

/// The floor geom with the contact settings that give Coulomb friction (for other models too).
std::string CoulombFloorMjcf(double mu);
/// Box `index` (geom "box<index>") with the floor's contact settings.
std::string CoulombBoxMjcf(const GroundBox& box, int index, double mu);

/// The MJCF for the model and contact settings (exposed for tests and tools).
std::string MakeMjcf(const dynamics::Model& model, const PlantConfig& config);

}  // namespace hyq::sim
