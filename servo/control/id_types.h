// What goes into and comes out of one inverse-dynamics call (the ID problem files of
// docs/inverse_dynamics.md carry exactly these fields).
//
// Units: contact unknowns are IMPULSES over one control period dt, in N·s. The force a contact
// applies is impulse / dt, in N. Torques in N·m.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "dynamics/model.h"
#include "qp/problem.h"
#include "servo/common/servo_types.h"

namespace hyq::servo {


/// One ID problem: the state, the desired joint accelerations and the contact situation.
struct IdInput {
  VectorQ q = VectorQ::Zero();             // docs/conventions.md
  VectorV v = VectorV::Zero();
  VectorJ qdd_des = VectorJ::Zero();       // desired joint accelerations, rad/s²
  std::array<bool, kNumFeet> stance{};     // lf, rf, lh, rh
  std::array<double, kNumFeet> mu{1.0, 1.0, 1.0, 1.0};  // Coulomb friction per foot
  std::array<Eigen::Vector3d, kNumFeet> normal_W{Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(),
                                                 Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()};
  double dt = 1e-3;                        // h of the paper: the control period, s
};

/// The impulse a stance foot receives over dt (N·s); force = impulse / dt.
struct ContactImpulse {
  bool active = false;
  double normal_Ns = 0.0;                               // along the contact normal
  Eigen::Vector3d tangent_Ns_W = Eigen::Vector3d::Zero();  // in the tangent plane, world frame
};

/// Which link of the fallback chain produced the torque.
enum class Fallback : std::uint8_t {
  kNone,            // the controller's own answer
  kStage1Torque,    // two-stage: Stage II failed, Stage I's torque used
  kContactFreeId,   // Stage I (or the no-slip decomposition) failed: contact-free ID
  kSafety,          // nothing usable (bad input): the caller's safety controller must act
};
const char* ToString(Fallback f) noexcept;

/// How one QP stage went.
struct StageReport {
  bool ran = false;
  qp::Status status = qp::Status::kBadInput;
  double objective = 0.0;     // Stage I: ½ v*ᵀ M v* up to a constant (eq 27); Stage II: ½ ‖τ‖²
  int iterations = 0;
  double solve_time_s = 0.0;
};

struct IdOutput {
  VectorJ tau_Nm = VectorJ::Zero();
  std::array<ContactImpulse, kNumFeet> impulses{};
  StageReport stage1, stage2;
  double kinetic_energy_J = 0.0;        // ½ v*ᵀ M v* after the step
  VectorV v_star = VectorV::Zero();     // predicted velocity after dt
  Fallback fallback = Fallback::kNone;
};

/// The stage whose QP a fallback came from: Stage II's for kStage1Torque, Stage I's otherwise.
inline const StageReport& FailedStage(const IdOutput& out) noexcept {
  return out.fallback == Fallback::kStage1Torque ? out.stage2 : out.stage1;
}

/// Whether out's fallback came from a QP that ran out of its time budget (Stage II's for
/// kStage1Torque, Stage I's for kContactFreeId) rather than its iterations: a preempted thread,
/// or a QP whose retries (SolveWithRetries) outlasted the budget.
inline bool FellBackOnDeadline(const IdOutput& out) noexcept {
  if (out.fallback != Fallback::kStage1Torque && out.fallback != Fallback::kContactFreeId)
    return false;
  return FailedStage(out).status == qp::Status::kDeadline;
}

/// For a fallback on the deadline: whether the thread, not the QP, used up the budget. The QP
/// checks its deadline every iteration (an iteration of the ID's QPs takes 1-20 us), so on its
/// own it ends within an iteration past the budget; its solve time (all attempts, wall clock)
/// under half the budget means the budget went before or between the attempts, and over 1.25×
/// means the thread was stalled inside (a preemption, or on a VM the vCPU descheduled, which the
/// guest charges to the thread's CPU time).
inline bool DeadlineSpentByAStall(const IdOutput& out, double budget_s) noexcept {
  if (!FellBackOnDeadline(out)) return false;
  const double t = FailedStage(out).solve_time_s;
  return t < 0.5 * budget_s || t > 1.25 * budget_s;
}

/// Counts of each fallback taken, for telemetry.
struct FallbackCounters {
  std::uint64_t calls = 0;
  std::uint64_t stage2_failed = 0;     // → Stage I torque
  std::uint64_t stage1_failed = 0;     // → contact-free ID
  std::uint64_t decomposition_failed = 0;
  std::uint64_t bad_input = 0;         // → safety
  std::uint64_t no_contact = 0;        // zero stance feet: contact-free ID by design
  std::uint64_t clamped = 0;           // fallback torques clamped to the effort limits
};

/// Clamps each joint torque to ±Model::limits[j].effort_Nm (the fallbacks' torques: the method's
/// own answer is never clamped here). Returns true if any joint was clamped. Never allocates.
bool ClampToEffortLimits(const dynamics::Model& model, VectorJ* tau_Nm) noexcept;

}  // namespace hyq::servo
