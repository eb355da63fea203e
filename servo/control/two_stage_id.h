// The two-stage contact-aware inverse dynamics of Zapolsky, Drumwright, Havoutis, Buchli and
// Semini, "Inverse Dynamics for a Quadruped Robot Locomoting Along Slippery Surfaces" (2015).
//
// Stage I (eqs 10–30). With the contact-free torques f_ID (servo/control/contact_free_id.h), the external
// forces f_ext = −h, and M = [A B; Bᵀ C], M⁻¹ = [D E; Eᵀ F] (13, 14):
//   j = v_b + [D E](h f_ext + [0; h f_ID]),  k = v_q + [Eᵀ F](h f_ext + [0; h f_ID])   (15, 16)
//   Z = ([D E] − E F⁻¹ [Eᵀ F]) R = A⁻¹ R_b,   p = j + E F⁻¹(v*_q − k) = j − A⁻¹B (v*_q − k)
//                                                                                   (21, 22)
// (the right-hand forms follow from the Schur complement identities; docs/inverse_dynamics.md),
// v*_b = Z z + p (23), and the QP in the impulses z
//   min ½ zᵀ ZᵀAZ z + zᵀ(ZᵀA p + ZᵀB v*_q)                                         (27)
//   s.t. Nᵀ v* ≥ 0 (28),  z ≥ 0 (29),  μ_i c_N,i − Σ_k c_D,ik ≥ 0 (30)
// with v*_q = q̇ + h q̈_des fixed (5). ZᵀAZ = R_bᵀ A⁻¹ R_b has rank ≤ 6: the QP solver handles
// the singular Hessian (qp/solver.h). The torque is recovered by (19):
//   x = F⁻¹(v*_q − k − [Eᵀ F] R z)/h = (F⁻¹(v*_q − k) − G z)/h,  G = R_q − (A⁻¹B)ᵀ R_b,
//   τ = f_ID + x.
//
// The linear term: eq 27 as printed makes ½ v*ᵀ M v* the objective; with the joints' v*_q
// prescribed that is not the maximal-dissipation principle the paper invokes (its gradient is not
// the contact velocity), and feet slide even on sticky ground. By default we keep the Hessian
// and use g = R_bᵀ p + R_qᵀ v*_q, whose gradient H z + g = Rᵀ v* is the contact velocity
// (StageOneObjective; derivation in docs/inverse_dynamics.md).
//
// Stage II (eqs 7–9). Every z + P w with P = null(Z) = null(R_b) gives the same v*, so the same
// kinetic energy, the same contact-point velocities and the same non-penetration rows: the
// motion is unchanged, only the impulses are redistributed. Along P the Stage I objective
// changes by gᵀP w (H P = 0), the work of the redistributed impulses on the contact velocities:
// zero on sticking contacts, not on sliding or separating ones. Stage I's optimal set is
// {feasible z : R_b z = R_b z*, gᵀz = gᵀz*}, so Stage II keeps gᵀP w = 0 (9), one equality row
// (none when ‖Pᵀg‖ is rounding-sized, TwoStageSettings::optimal_set_tolerance). Among them,
//   min ½ ‖τ(z + P w)‖² = ½ ‖τ_I − G P w / h‖²   s.t.  z + P w ≥ 0, friction rows, gᵀP w = 0.
// (The paper's eq 7 minimises ‖τ‖; its authors' code minimised ‖τ − f_ID‖.)
//
// Fallbacks, each counted (FallbackCounters), never an exception or an allocation:
// Stage II fails → Stage I's torque; Stage I fails → contact-free ID; bad input → kSafety.
// A fallback torque is clamped per joint to the model's effort limits (counted in
// FallbackCounters::clamped; v_star and the impulses stay those of the unclamped torque).
// Zero stance feet: the contact-free ID is the answer.
#pragma once

#include <chrono>
#include <limits>
#include <optional>

#include "dynamics/cycle_dynamics.h"
#include "hal/config_key.h"
#include "qp/solver.h"
#include "servo/control/contact_model.h"
#include "servo/control/pivoted_qr.h"

namespace hyq::servo {

/// The linear term of the Stage I QP (docs/inverse_dynamics.md, "Stage I objective").
enum class StageOneObjective : std::uint8_t {
  /// g = R_bᵀ p + R_qᵀ v*_q: the gradient of the objective is the contact-point velocity Rᵀv*,
  /// so the KKT conditions are those of maximal dissipation (a contact inside its friction cone
  /// sticks). Default.
  kMaximumDissipation,
  /// g = ZᵀA p + ZᵀB v*_q, eq 27 as printed (½ v*ᵀ M v* with v*_q fixed): it drives the base
  /// towards zero momentum and lets feet slide even on high friction.
  kKineticEnergy,
};
const char* ToString(StageOneObjective o) noexcept;

struct TwoStageSettings {
  StageOneObjective objective = StageOneObjective::kMaximumDissipation;
  /// The h of eqs 5–6 used by the controllers (servo/control/controller.h), s; 0: the control period.
  /// The method corrects contact-point velocities within h, so h = 1 ms makes a very stiff
  /// loop on compliant contact (docs/inverse_dynamics.md, "Horizon").
  double horizon_s = 0.0;
  /// Project the measured v M-orthogonally onto J_c v = 0 (what an inelastic impact of the
  /// stance contacts would leave) before Stage I, so that the method does not try to cancel,
  /// within h, contact-point velocities that the rigid-contact model says cannot exist (on a
  /// compliant ground they would make a deadbeat loop of gain 1/h: docs/inverse_dynamics.md,
  /// "Measured contact velocities"). A no-op when v is already contact-consistent.
  bool project_contact_velocity = true;
  /// Make q̈_des velocity-level consistent with the stance contacts before Stage I
  /// (MakeVelocityConsistent): with three or four feet a joint motion leaves, in general, no base
  /// motion that keeps every stance foot at rest after the step of eqs 5–6, so the prescribed
  /// v*_q makes the feet slide, Stage I's optimum is a single torque and eq 9 pins Stage II to it.
  /// Sources: PD feedback on the stance legs, and a reference consistent at the acceleration
  /// level (J_c v̇ = −J̇_c v) rather than at the velocity level (J_c (v + h v̇) = 0).
  /// docs/inverse_dynamics.md, "Velocity-level consistent q̈_des".
  bool velocity_consistent_qdd = true;
  int tangent_directions = 4;   // r
  bool stage2 = true;           // false: the paper's "Stage I only" (Fig. 1)
  int max_iterations = 500;     // Stage I QP (degenerate near-frictionless cases need ~150)
  int stage2_max_iterations = 500;
  /// Time budget per QP (none by default; config controller.two_stage.time_budget_us), on
  /// time_budget_clock: wall time, or the thread's CPU time, which the servo loop sets under the
  /// lock-step clock (the plant waits; qp/deadline.h).
  std::optional<std::chrono::nanoseconds> time_budget;
  qp::DeadlineClock time_budget_clock = qp::DeadlineClock::kMonotonic;
  double null_space_tolerance = 1e-9;  // relative, rank decision for the internal forces
  /// Stage II stays in Stage I's optimal set (9) by keeping gᵀP w = 0; ‖Pᵀg‖∞ at or below this
  /// times ‖|P|ᵀ|g|‖∞ (the size of the rounding in Pᵀg) counts as zero and adds no row. 1 (or
  /// more) drops the row (comparison only: Stage II may then leave Stage I's optimum on sliding
  /// contacts; docs/inverse_dynamics.md).
  double optimal_set_tolerance = 1e-9;
  /// A contact with μ at or below this is frictionless: its tangential impulses are fixed at 0
  /// (instead of being squeezed to 0 by nearly dependent friction rows).
  double frictionless_mu = 1e-6;
  /// The proximal weight of both QPs (qp::Settings::proximal_weight, relative to max H_ii); both
  /// Hessians are singular (Stage I rank ≤ 6, Stage II rank ≤ 12 and often 1–6). The library's
  /// 1e-7 let the outer loop shrink ε to 1e-9 on degenerate Stage II QPs, whose subproblems then
  /// lost feasibility to rounding (primal residual 1e-7…1e-3): 32 of the 6000 solves of the
  /// hard-problem generator fell back; with 1e-5, none (docs/inverse_dynamics.md, "Fallbacks").
  double qp_proximal_weight = 1e-5;

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("objective", &objective)
                 .Choices({{"maximum_dissipation", StageOneObjective::kMaximumDissipation},
                           {"kinetic_energy", StageOneObjective::kKineticEnergy}})
                 .Doc("Stage I's objective (kinetic_energy: eq 27 as printed)"));
    a->Visit(hal::Key("horizon_s", &horizon_s).In(0.0, 0.1).Unit("s")
                 .Doc("h of eqs 5–6; 0: the control period"));
    a->Visit(hal::Key("project_contact_velocity", &project_contact_velocity)
                 .Doc("project the measured v onto J_c v = 0 before Stage I"));
    a->Visit(hal::Key("velocity_consistent_qdd", &velocity_consistent_qdd)
                 .Doc("make q̈_des velocity-level consistent with the stance contacts"));
    a->Visit(hal::Key("max_iterations", &max_iterations).In(10, 10000).Doc("Stage I QP"));
    a->Visit(hal::Key("stage2_max_iterations", &stage2_max_iterations).In(10, 10000).Doc("Stage II QP"));
    a->Visit(hal::Key("time_budget_us", &time_budget).In(10.0, 1e6).Unit("µs")
                 .Doc("per QP; past it the fallback chain takes over (absent: none)"));
    a->Visit(hal::Key("tangent_directions", &tangent_directions).In(4, 4)
                 .Doc("friction-cone edges r (HyQ's QP is sized for 4)"));
    // the stage1 controller kind turns Stage II off regardless
    a->Visit(hal::Key("stage2", &stage2).Doc("false: the paper's \"Stage I only\""));
    a->Visit(hal::Key("null_space_tolerance", &null_space_tolerance).In(1e-15, 1e-3)
                 .Doc("relative rank decision for the internal forces"));
    a->Visit(hal::Key("frictionless_mu", &frictionless_mu).In(0.0, 0.01)
                 .Doc("a contact with μ at or below this is frictionless"));
    // Stage II held in Stage I's optimal set (eq 9) with this rounding tolerance
    a->Visit(hal::Key("optimal_set_tolerance", &optimal_set_tolerance).In(0.0, 1.0)
                 .Doc("Stage II inside Stage I's optimum (eq 9) within this; 1 drops the row"));
  }
};

/// Replaces the stance legs' part of *qdd_des by its Euclidean projection onto the joint
/// accelerations that, with some base acceleration, bring every stance contact point to rest
/// after one step of h from v: {q̈ : ∃ a_b, J_c (v + h [a_b; q̈]) = 0}. Swing legs are untouched;
/// with one stance foot every q̈ qualifies (with two, all but turning about the line between them). Returns false, leaving *qdd_des as given,
/// when a stance leg's 3 × 3 joint block is singular (knee straight). Never allocates.
bool MakeVelocityConsistent(const ContactSet& set, const VectorV& v, double h,
                            VectorJ* qdd_des) noexcept;

/// v ← v − M⁻¹J_cᵀ (J_c M⁻¹ J_cᵀ)⁻¹ J_c v for the stance contacts of `set` (J_c: their contact
/// point Jacobians): the M-orthogonal projection onto J_c v = 0, the velocity an inelastic impact
/// of those contacts would leave. From M's factorisation in `dyn` and J_c's structure (each
/// contact on the base and its own leg), without an 18-dof solve per row of J_c. Returns false,
/// leaving *v as given, when J_c M⁻¹ J_cᵀ does not factor (dependent contact rows). Never
/// allocates.
bool ProjectContactVelocity(const ContactSet& set, const dynamics::CycleDynamics& dyn,
                            VectorV* v) noexcept;

/// The QP settings of both stages (and, with a large weight, of the last attempt): the given
/// proximal weight, and the Hessians known to be singular.
qp::Settings IdQpSettings(double proximal_weight = TwoStageSettings{}.qp_proximal_weight) noexcept;

enum class [[nodiscard]] IdStatus : std::uint8_t { kOk, kFallback, kBadInput };
const char* ToString(IdStatus s) noexcept;

class TwoStageId {
 public:
  /// Allocates the QP workspaces (configuration time).
  explicit TwoStageId(const TwoStageSettings& settings = {});

  /// Solves one ID problem. `dyn` must be ComputeCycleDynamics(model, in.q, in.v). Returns kOk
  /// when the torque is the method's own answer, kFallback when a fallback produced it (see
  /// out->fallback), kBadInput when nothing usable could be computed (out->tau is zero and
  /// out->fallback is kSafety). Never throws or allocates. `h` is the bias forces the ID
  /// balances: dyn.bias, or that bias corrected by an estimated disturbance (h − [d_b; 0]).
  IdStatus Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                 const dynamics::VectorV& h, const IdInput& in, IdOutput* out) noexcept;
  /// As above with the model's h = dyn.bias.
  IdStatus Solve(const dynamics::Model& model, const dynamics::CycleDynamics& dyn,
                 const IdInput& in, IdOutput* out) noexcept {
    return Solve(model, dyn, dyn.bias, in, out);
  }

  const FallbackCounters& counters() const noexcept { return counters_; }
  const TwoStageSettings& settings() const noexcept { return settings_; }
  /// The last Stage I / Stage II problems (for recording QP instances and for tests).
  const qp::Problem& stage1_problem() const noexcept { return p1_; }
  const qp::Problem& stage2_problem() const noexcept { return p2_; }
  const ContactSet& contacts() const noexcept { return set_; }
  /// Forget the warm-start state (e.g. after a controller switch).
  void Reset() noexcept;

 private:
  void RunStage1(const dynamics::CycleDynamics& dyn, const dynamics::VectorV& h_bias,
                 const IdInput& in, const VectorJ& f_id) noexcept;
  bool RunStage2(double h, IdOutput* out) noexcept;
  qp::Budget MakeBudget(bool warm, int max_iterations) const noexcept;

  TwoStageSettings settings_;
  ContactSet set_;
  std::array<bool, kNumFeet> last_stance_{};
  bool have_last_ = false;

  // Stage I data (sizes n_z = set_.num_impulses())
  Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxImpulses> Z_;
  Eigen::Matrix<double, dynamics::kNumJoints, Eigen::Dynamic, Eigen::ColMajor,
                dynamics::kNumJoints, kMaxImpulses> G_;   // R_q − (A⁻¹B)ᵀ R_b
  dynamics::Vector6d p_;
  VectorJ v_star_q_, k_;
  qp::Problem p1_;
  qp::Solution s1_;
  qp::Solver solver1_;

  // Stage II data. null(R_b) = lifted internal forces (null of the 6 × 3n base-wrench map,
  // from a QR of its transpose) + per contact the r − 2 combinations of tangent directions that
  // cancel (fixed for a given r: tangent_null_)
  static constexpr int kMaxForceRows = 3 * kMaxContacts;
  PivotedQr<kMaxForceRows, 6> qr_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxForceRows,
                kMaxForceRows> Qw_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxTangents,
                kMaxTangents> tangent_null_;  // r × (r − 2)
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxImpulses,
                kMaxImpulses> P_;
  bool BuildNullSpace() noexcept;
  bool OptimalSetRow(qp::VectorN* row) const noexcept;
  Eigen::Matrix<double, dynamics::kNumJoints, Eigen::Dynamic, Eigen::ColMajor,
                dynamics::kNumJoints, kMaxImpulses> GP_;
  int null_dim_ = 0;
  int internal_cols_ = 0;  // P's leading columns that are internal forces (the rest: tangent pairs)
  // per cancelling column of P (after the internal ones): the contact whose tangents it combines
  std::array<int, kMaxContacts * kMaxTangents> cancel_contact_{};
  int last_null_dim_ = -1;
  qp::Problem p2_;
  qp::Solution s2_;
  qp::Solver solver2_;
  qp::Solver last_resort_;  // either stage's last attempt (SolveWithRetries)

  FallbackCounters counters_;
  IdInput consistent_;
};

}  // namespace hyq::servo
