// Internal: dual active-set method for one strictly convex subproblem, in the style of DAQP
// [Arnström, Bemporad, Axehill, "A dual active-set solver for embedded quadratic programming
// using recursive LDLᵀ updates", IEEE TAC 67(8), 2022, Algorithm 2] and Goldfarb–Idnani
// [Math. Programming 27, 1983].
//
// The proximal subproblem (qp/solver.cc) in the step δ = x − x_k,
//   min ½ δᵀ (H + εI) δ + qᵀ δ   s.t.  lo_i − C_i x_k ≤ C_i δ ≤ hi_i − C_i x_k,          (1)
// becomes, with H + εI = L Lᵀ, u = Lᵀ δ + v, v = L⁻¹ q and m_i = L⁻¹ C_iᵀ, the least-distance
// problem (LDP)
//   min ½ ‖u‖²   s.t.  m_iᵀ u ≤ hi_i − C_i x_k + m_iᵀ v   (and the lower sides)         (2)
// whose dual is max −½ λᵀ M_W M_Wᵀ λ − dᵀλ, λ ≥ 0. For a working set W of signed rows,
//   λ* = −(M_W M_Wᵀ)⁻¹ d_W,   u = −M_Wᵀ λ                                                (3)
// If λ* ≥ 0 the most violated row enters W; otherwise λ steps towards λ* until a multiplier
// reaches 0 and that row leaves W. An entering row that is linearly dependent on W gives a
// direction in λ along which u stays put; if no multiplier blocks it the problem is infeasible and
// the direction is a Farkas certificate (Arnström et al., Sec. III-C).
// M_W M_Wᵀ = Lw Dw Lwᵀ is updated, never refactorised: an entering row appends a row to Lw; a
// leaving row is deleted with a rank-one update of the trailing block [Gill, Golub, Murray,
// Saunders, Math. Comp. 28, 1974, method C1].
#pragma once

#include "qp/deadline.h"
#include "qp/workspace.h"

namespace hyq::qp::internal {

enum class InnerStatus { kOptimal, kInfeasible, kIterationLimit, kDeadline };

struct InnerLimits {
  int max_iterations = 0;
  bool has_deadline = false;
  Deadline deadline;
  double primal_tolerance = 0.0;
  double dependence_tolerance = 0.0;
};

/// H + eps I = L Lᵀ from the lower triangle of H, and L⁻¹. False when a pivot is not above
/// relative_floor · (max_i H_ii + eps) (or not positive), or when relative_floor > 0 and
/// max_i H_ii ‖L⁻¹‖_F² > 1 / relative_floor (a condition-number test). Needs ws->hmax.
bool FactorHessian(Workspace* ws, double eps, double relative_floor) noexcept;

/// d_p for every p in W, after v and C x_k changed.
void RefreshRightHandSides(Workspace* ws) noexcept;

/// Puts row `row` on side `sign` into W with multiplier `lambda` unless it is linearly dependent
/// on W (then returns false). For warm starts and after a refactorisation.
bool AppendIfIndependent(Workspace* ws, int row, int sign, double lambda,
                         double dependence_tolerance) noexcept;

/// Takes position j out of W (LDLᵀ downdate).
void RemoveFromWorkingSet(Workspace* ws, int j) noexcept;

/// Recomputes every m_p and the LDLᵀ factors of W after L changed; dependent rows are dropped.
void RebuildWorkingSet(Workspace* ws, double dependence_tolerance) noexcept;

/// Runs (3) from the current W and λ (λ ≥ 0 on inequality rows). On kOptimal, δ and C δ hold the
/// subproblem's solution; on kInfeasible ws->cert holds the Farkas multipliers over rows.
/// scan_first: start by looking for a violated row at the current δ and C δ (after refinement)
/// instead of recomputing λ* and δ.
InnerStatus SolveSubproblem(Workspace* ws, const InnerLimits& limits, int* iterations,
                            bool scan_first = false) noexcept;

/// C δ = [δ; A δ] from the current δ.
void ComputeRowSteps(Workspace* ws) noexcept;

/// One step of iterative refinement of the subproblem's KKT system on the fixed working set W:
///   r_x = (H + εI) δ + q + Σ_p s_p λ_p C_pᵀ,   r_c,p = C_p (x_k + δ) − b_p   (original data)
///   solve the equality-constrained (1) in (Δδ, Δλ) with right-hand sides (r_x, r_c) through
///   the same L and Lw Dw Lwᵀ, then δ += Δδ, λ += Δλ.
/// The factorisations' rounding errors then act on the residuals, not on x and λ, so the
/// subproblem is solved to working accuracy even when cond(H) is large. Returns ‖Δδ‖∞.
double RefineOnWorkingSet(Workspace* ws) noexcept;

/// u, δ and C δ from the current λ.
void ComputeStep(Workspace* ws) noexcept;

}  // namespace hyq::qp::internal
