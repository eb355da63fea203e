// Dense convex QP solver for the servo loop: proximal-point outer iterations around a dual
// active-set inner solver (qp/dual_active_set.h), so that a singular H (the Stage I Hessian ZᵀAZ
// has rank ≤ 6) is handled without changing the answer:
//   x_{k+1} = argmin ½ xᵀHx + gᵀx + ε/2 ‖x − x_k‖²  s.t. the constraints               (1)
// [Rockafellar, "Monotone operators and the proximal point algorithm", SIAM J. Control Optim.
// 14(5), 1976; DAQP offers the same for semi-definite QPs and LPs (its eps_prox setting)].
// Each (1) is strictly convex;
// the iteration stops when the KKT conditions of the *unregularised* problem hold to
// Settings::kkt_tolerance, because at a fixed point of (1) the proximal term vanishes. When H is
// safely positive definite ε = 0 and (1) is plain iterative refinement.
// Design, statuses and measured speed: docs/qp.md.
#pragma once

#include <memory>

#include "qp/problem.h"

namespace hyq::qp {

namespace internal {
struct Workspace;
}

class Solver {
 public:
  /// Allocates the workspace (the only allocation the solver ever makes).
  explicit Solver(const Settings& settings = Settings{});
  ~Solver();
  Solver(Solver&&) noexcept;
  Solver& operator=(Solver&&) noexcept;
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  /// Solves p within budget. Fills every field of *solution (sized n, m); on kIterationLimit and
  /// kDeadline x is the last proximal iterate (feasible once one outer iteration completed) and
  /// kkt says how good it is. With budget.warm_start, *solution is read first as the starting
  /// active set (see Budget). Never allocates, never throws.
  Status Solve(const Problem& p, const Budget& budget, Solution* solution) noexcept;

  const Settings& settings() const noexcept { return settings_; }

 private:
  Settings settings_;
  std::unique_ptr<internal::Workspace> ws_;
};

/// Checks sizes, finiteness and bound order (the kBadInput conditions). Allocates nothing.
bool IsWellFormed(const Problem& p) noexcept;

}  // namespace hyq::qp
