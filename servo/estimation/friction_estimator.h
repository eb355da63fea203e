// Online friction estimation per foot (docs/friction_estimation.md): the μ the
// two-stage ID's Stage I uses (Zapolsky et al. eq 30, μ_i c_N,i − Σ_k c_D,ik ≥ 0), measured from
// what HyQ senses instead of assumed.
//
// For each stance foot, from the ground's force on it f (the leg's load cells through its
// Jacobian, FootForceFromJointTorques) and the tangential velocity of its contact point v_t (leg
// kinematics and the estimated base velocity), with f_n = f·n, f_t = f − f_n n, ρ = |f_t| / f_n:
//   sticking (|v_t| < stick speed):  μ ≥ ρ (Coulomb: a sticking contact is inside its cone), so
//                                    μ̂ ← max(μ̂, ρ); with no slip the estimate also rises
//                                    towards the prior at a bounded rate (probing), its
//                                    confidence decaying, as it is a guess above what was seen;
//   slipping (|v_t| > slip speed for N cycles, and f_t opposing v_t: −f_t·v_t ≥ a |f_t||v_t|,
//                                    as Coulomb friction on a sliding contact does):  ρ = μ (the
//                                    contact is on its cone), so μ̂ ← ρ at once on the first
//                                    slipping cycle and filtered while the slip lasts, confidence 1.
// The first touchdown_blank_s of a footfall prove nothing either way: the impact's accelerations
// are what the force estimate neglects, and the foot settles. Nor does a cycle in which the state
// estimator does not vouch for the base velocity the foot's slip velocity is measured against
// (Update's evidence_ok: a base velocity dragged by another, slipping foot makes a sticking foot
// look like it slips). Both hold μ̂ and restart the slip count. A foot that lifts off leaves its
// estimate at the place it landed (a fixed ring of places); a footfall within the memory radius
// of a remembered place starts from that estimate, elsewhere from the prior. Stage I gets μ_ctrl = clamp((1 − margin) μ̂, min_mu, upper bound), where the
// upper bound is the configured or operator-commanded μ of that foot.
// Sources: the Coulomb cone as the paper's eq 30 uses it; slip detected from the stance foot's
// velocity (leg kinematics and the base estimate) and the ground reaction from the leg's torques,
// as Focchi et al. do on HyQ ("Slip detection and recovery for quadruped robots", ISRR 2015),
// who also take ρ at slip as the surface's friction.
//
// Never allocates or throws after construction.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Dense>

#include "dynamics/cycle_dynamics.h"
#include "hal/config_key.h"
#include "servo/common/servo_types.h"

namespace hyq::servo {

struct FrictionEstimatorConfig {
  bool enabled = false;            // off: Stage I gets the configured or commanded μ as it is
  double prior_mu = 1.0;           // a footfall on ground not seen before starts here
  double min_mu = 0.05;            // floor of the estimate and of what Stage I gets
  double margin = 0.2;             // Stage I gets (1 − margin) μ̂
  double min_normal_N = 40.0;      // a foot carrying less proves nothing
  double slip_speed_m_s = 0.04;    // tangential contact-point speed that is a slip ...
  int slip_cycles = 3;             // ... for this many cycles in a row ...
  double slip_alignment = 0.7;     // ... with −f_t·v_t at least this × |f_t||v_t|
  double touchdown_blank_s = 0.03; // a footfall's first this-many seconds prove nothing
  double stick_speed_m_s = 0.015;  // below this the foot sticks
  double rise_per_s = 1.0;         // a sticking foot's μ̂ rises towards the prior this fast
  double slip_filter = 0.2;        // weight of each further slipping cycle's ρ in μ̂
  double confidence_time_s = 0.5;  // a guessed rise halves the confidence in ln 2 × this
  double memory_radius_m = 0.2;    // a footfall this close to a remembered place starts there

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled)
                 .Doc("true: Stage I gets (1 − margin) μ̂ instead of contact.mu"));
    a->Visit(hal::Key("prior_mu", &prior_mu).In(0.0, 2.0)
                 .Doc("a footfall on ground not seen before starts here"));
    a->Visit(hal::Key("min_mu", &min_mu).In(0.0, 2.0)
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v > prior_mu) return hal::Violation{"at most prior_mu (" + std::to_string(prior_mu) + ")"};
                   return std::nullopt;
                 })
                 .Doc("floor of the estimate and of what Stage I gets (at most prior_mu)"));
    a->Visit(hal::Key("margin", &margin).In(0.0, 0.9).Doc("Stage I gets (1 − margin) μ̂"));
    a->Visit(hal::Key("min_normal_N", &min_normal_N).In(1.0, 5000.0).Unit("N")
                 .Doc("a foot carrying less proves nothing"));
    a->Visit(hal::Key("slip_speed_m_s", &slip_speed_m_s).In(1e-4, 10.0).Unit("m/s")
                 .Doc("tangential contact-point speed that is a slip ..."));
    a->Visit(hal::Key("slip_cycles", &slip_cycles).In(1, 1000)
                 .Doc("... for this many cycles in a row ..."));
    a->Visit(hal::Key("slip_alignment", &slip_alignment).In(-1.0, 1.0)
                 .Doc("... with −f_t·v_t at least this × |f_t||v_t|"));
    a->Visit(hal::Key("touchdown_blank_s", &touchdown_blank_s).In(0.0, 1.0).Unit("s")
                 .Doc("a footfall's first this-many seconds prove nothing"));
    a->Visit(hal::Key("stick_speed_m_s", &stick_speed_m_s).In(0.0, 10.0).Unit("m/s")
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v > slip_speed_m_s)
                     return hal::Violation{"at most slip_speed_m_s (" + std::to_string(slip_speed_m_s) + ")"};
                   return std::nullopt;
                 })
                 .Doc("below this the foot sticks (at most slip_speed_m_s)"));
    a->Visit(hal::Key("rise_per_s", &rise_per_s).In(0.0, 100.0).Unit("1/s")
                 .Doc("a sticking foot's μ̂ rises towards the prior this fast"));
    a->Visit(hal::Key("slip_filter", &slip_filter).In(0.0, 1.0)
                 .Doc("weight of each further slipping cycle's ratio in μ̂"));
    a->Visit(hal::Key("confidence_time_s", &confidence_time_s).In(1e-3, 1e4).Unit("s")
                 .Doc("a guessed rise halves the confidence in ln 2 × this"));
    a->Visit(hal::Key("memory_radius_m", &memory_radius_m).In(0.0, 10.0).Unit("m")
                 .Doc("a footfall this close to a remembered place starts from its estimate"));
  }
};

/// What the estimator sees of one foot in one cycle (world frame, flat ground: normal +z).
struct FootFrictionInput {
  bool stance = false;                                       // the state estimator's stance
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();         // ground on foot, N
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();      // contact point, m/s
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();      // foot, m
};

/// One foot's estimate (published on HYQ_FRICTION).
struct FootFriction {
  double mu = 1.0;            // μ̂, the estimate
  double mu_control = 1.0;    // what Stage I gets
  double confidence = 0.0;    // 1 just after a slip measured μ; 0 for the prior
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();  // measured ground force, N
  double ratio = 0.0;         // ρ = |f_t| / f_n this cycle (0 unloaded)
  double slip_speed_m_s = 0.0;
  double lower_bound = 0.0;   // the largest sticking ρ of this stance
  bool loaded = false;        // in stance and carrying at least min_normal_N
  bool slipping = false;
  bool evidence_held = false;  // loaded and past the blank, but evidence_ok false: μ̂ held
  std::uint32_t slips = 0;    // slip events (a new slip after sticking or a new footfall)
  std::uint32_t footfalls = 0;
  std::uint32_t held_cycles = 0;  // cycles evidence_held (since Reset)
};

class FrictionEstimator {
 public:
  static constexpr int kMemory = 32;  // remembered places, the oldest replaced

  explicit FrictionEstimator(const FrictionEstimatorConfig& config);

  const FrictionEstimatorConfig& config() const noexcept { return config_; }
  /// Forgets every place and starts each foot from the prior.
  void Reset() noexcept;

  /// One cycle of dt seconds; `evidence_ok` per foot: the base velocity the foot's slip velocity
  /// is measured against can be trusted this cycle (false: the foot neither raises nor lowers
  /// μ̂, its slip count restarts, evidence_held says so); `upper_mu` the configured or commanded μ
  /// per foot.
  void Update(const std::array<FootFrictionInput, kNumFeet>& in,
              const std::array<bool, kNumFeet>& evidence_ok,
              const std::array<double, kNumFeet>& upper_mu, double dt) noexcept;

  const std::array<FootFriction, kNumFeet>& feet() const noexcept { return feet_; }
  const FootFriction& foot(int f) const noexcept { return feet_[static_cast<std::size_t>(f)]; }

 private:
  struct Place {
    double x = 0.0, y = 0.0, mu = 0.0, confidence = 0.0;
    bool used = false;
  };
  void Remember(const Eigen::Vector3d& p_W, const FootFriction& foot) noexcept;
  const Place* Recall(const Eigen::Vector3d& p_W) const noexcept;

  FrictionEstimatorConfig config_;
  std::array<FootFriction, kNumFeet> feet_{};
  std::array<int, kNumFeet> slip_run_{};
  std::array<double, kNumFeet> loaded_s_{};                // time since the footfall
  std::array<Eigen::Vector3d, kNumFeet> touchdown_W_{};    // where it landed
  std::array<Place, kMemory> places_{};
  int next_place_ = 0;
};

/// The ground's force on foot `leg` (world, N) from its measured joint torques: the leg's rows of
/// M v̇ + h = Sᵀ τ + Σ_i J_iᵀ f_i with v̇ neglected and only this foot's Jacobian reaching them,
///   J_legᵀ f = h_leg − τ_leg,   J_leg the foot's 3 × 3 Jacobian block over the leg's joints.
/// Zero when J_leg is singular (a stretched leg). Never allocates.
Eigen::Vector3d FootForceFromJointTorques(const dynamics::CycleDynamics& dyn, int leg,
                                          const Eigen::Vector3d& tau_leg_Nm) noexcept;

/// What the estimator sees of foot `leg`: the force above, the velocity of the sphere's lowest
/// point (the contact point on flat ground, v_F + w × (−r ẑ): a rolling foot does not slip) and
/// the foot's position, for the state `dyn` was computed at (ComputeCycleDynamics(q, v)).
FootFrictionInput MeasureFoot(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                              const dynamics::VectorV& v, int leg, bool stance,
                              const Eigen::Vector3d& tau_leg_Nm) noexcept;

}  // namespace hyq::servo
