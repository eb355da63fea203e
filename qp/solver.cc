#include "qp/solver.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "qp/dual_active_set.h"
#include "qp/workspace.h"

namespace hyq::qp {
namespace {

using internal::InnerStatus;
using internal::kN;
using internal::Workspace;
using Clock = std::chrono::steady_clock;

// A pivot below this fraction of max H_ii means H is (numerically) singular: use ε > 0.
constexpr double kPositiveDefiniteFloor = 1e-11;
// ε is divided by this when the proximal iterations converge slowly, down to kMinRelativeEps.
constexpr double kEpsReduction = 1e-2;
constexpr double kMinRelativeEps = 1e-9;
// A proximal step δ is a direction of unboundedness when, normalised, these hold (relative).
constexpr double kRayTolerance = 1e-8;
// Refinement steps per outer iteration (each costs about one active-set iteration).
constexpr int kMaxRefinements = 3;

double MaxAbs(const double* a, int n) {
  double s = 0.0;
  for (int i = 0; i < n; ++i) s = std::max(s, std::fabs(a[i]));
  return s;
}

// cx = C x_k, q = H x_k + g, v = L⁻¹ q; H x_k and A x_k from the last KKT check when it was
// made at x_k (ws->products_valid)
template <int N>
void LineariseN(Workspace* ws) {
  const Problem& p = *ws->problem;
  const int n = internal::Size<N>(*ws), m = ws->m;
  for (int i = 0; i < n; ++i) ws->cx[i] = ws->xk[i];
  if (ws->products_valid) {
    for (int i = 0; i < n; ++i) ws->q[i] = p.g(i) + ws->kkt_hx[i];
    for (int k = 0; k < m; ++k) ws->cx[n + k] = ws->kkt_ax[k];
  } else {
    for (int i = 0; i < n; ++i)
      ws->q[i] = p.g(i) + internal::Dot(p.H.data() + i * n, ws->xk.data(), n);
    internal::MultiplyA<N>(p, ws->xk.data(), ws->cx.data() + n);
  }
  ws->products_valid = false;
  for (int i = 0; i < n; ++i) ws->v[i] = ws->q[i];
  internal::ForwardChol<N>(*ws, ws->v.data(), 0);
}

void Linearise(Workspace* ws) {
  internal::WithSize(ws->n, [&](auto n) { LineariseN<n()>(ws); });
}

// the KKT residuals of the iterate WriteIterate left in *sol, keeping H x and A x for Linearise
KktResiduals CheckIterate(Workspace* ws, const Solution& sol) {
  // WriteIterate set the multipliers of W's rows and zeroed the rest
  const KktResiduals r = internal::KktResidualsAndProducts(
      *ws->problem, sol.x, sol.y_bounds, sol.y_constraints, ws->kkt_hx.data(), ws->kkt_ax.data(),
      ws->w_row.data(), ws->nw);
  ws->products_valid = true;
  return r;
}

// x, multipliers and active set from x_k + δ and W
void WriteIterate(const Workspace& ws, Solution* sol) {
  const int n = ws.n, m = ws.m;
  for (int i = 0; i < n; ++i) sol->x(i) = ws.xk[i] + ws.delta[i];
  sol->y_bounds.setZero(n);
  sol->y_constraints.setZero(m);
  for (int i = 0; i < ws.rows; ++i) {
    const Active a = ws.is_eq[i] ? Active::kEquality : Active::kInactive;
    if (i < n) sol->active_bounds[i] = a;
    else sol->active_constraints[i - n] = a;
  }
  for (int p = 0; p < ws.nw; ++p) {
    const int row = ws.w_row[p];
    const double y = ws.w_sign[p] * ws.lambda[p];
    const Active a = ws.is_eq[row] ? Active::kEquality
                                   : (ws.w_sign[p] > 0 ? Active::kUpper : Active::kLower);
    if (row < n) {
      sol->y_bounds(row) = y;
      sol->active_bounds[row] = a;
    } else {
      sol->y_constraints(row - n) = y;
      sol->active_constraints[row - n] = a;
    }
  }
}

double ObjectiveFromProducts(const Problem& p, const VectorN& x, const double* hx) {
  double f = 0.0;
  for (int i = 0; i < p.n(); ++i) f += x(i) * (0.5 * hx[i] + p.g(i));
  return f;
}

double Objective(const Problem& p, const VectorN& x) {
  double hx[kN];
  for (int i = 0; i < p.n(); ++i) hx[i] = internal::Dot(p.H.data() + i * p.n(), x.data(), p.n());
  return ObjectiveFromProducts(p, x, hx);  // H symmetric: row i is column i
}

// δ / ‖δ‖ is a certificate of unboundedness: H r ≈ 0, gᵀ r < 0 and r in the recession cone.
bool IsRay(const Workspace& ws, double* r) {
  const Problem& p = *ws.problem;
  const int n = ws.n, m = ws.m;
  const double dmax = MaxAbs(ws.delta.data(), n);
  if (!(dmax > 1e-6 * (1.0 + MaxAbs(ws.xk.data(), n)))) return false;
  for (int i = 0; i < n; ++i) r[i] = ws.delta[i] / dmax;
  double gr = 0.0;
  for (int i = 0; i < n; ++i) {
    double hr = 0.0;
    for (int j = 0; j < n; ++j) hr += p.H(i, j) * r[j];
    if (std::fabs(hr) > kRayTolerance * std::max(ws.hmax, 1e-300)) return false;
    gr += p.g(i) * r[i];
  }
  if (!(gr < -kRayTolerance * std::max(MaxAbs(p.g.data(), n), 1e-300))) return false;
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(p.ub(i)) && r[i] > kRayTolerance) return false;
    if (std::isfinite(p.lb(i)) && r[i] < -kRayTolerance) return false;
  }
  for (int k = 0; k < m; ++k) {
    double ar = 0.0, anorm = 0.0;
    for (int j = 0; j < n; ++j) {
      ar += p.A(k, j) * r[j];
      anorm = std::max(anorm, std::fabs(p.A(k, j)));
    }
    if (std::isfinite(p.ubA(k)) && ar > kRayTolerance * anorm) return false;
    if (std::isfinite(p.lbA(k)) && ar < -kRayTolerance * anorm) return false;
  }
  return true;
}

void SizeSolution(Solution* sol, int n, int m) {
  sol->x.setZero(n);
  sol->y_bounds.setZero(n);
  sol->y_constraints.setZero(m);
  sol->direction.setZero(n);
  sol->active_bounds.fill(Active::kInactive);
  sol->active_constraints.fill(Active::kInactive);
}

// 0 · v is NaN exactly when v is NaN or ±Inf: one pass per array, four partial sums
bool AllFinite(const double* v, Eigen::Index size) noexcept {
  double z0 = 0.0, z1 = 0.0, z2 = 0.0, z3 = 0.0;
  Eigen::Index i = 0;
  for (; i + 4 <= size; i += 4) {
    z0 += 0.0 * v[i];
    z1 += 0.0 * v[i + 1];
    z2 += 0.0 * v[i + 2];
    z3 += 0.0 * v[i + 3];
  }
  for (; i < size; ++i) z0 += 0.0 * v[i];
  return (z0 + z1) + (z2 + z3) == 0.0;
}

}  // namespace

bool IsWellFormed(const Problem& p) noexcept {
  const auto n = p.H.rows(), m = p.A.rows();
  if (n < 1 || p.H.cols() != n || p.g.size() != n || p.lb.size() != n || p.ub.size() != n)
    return false;
  if ((m > 0 && p.A.cols() != n) || p.lbA.size() != m || p.ubA.size() != m) return false;
  if (!AllFinite(p.H.data(), n * n) || !AllFinite(p.g.data(), n) ||
      !AllFinite(p.A.data(), m * n))
    return false;
  // symmetry, relative to max |H_ij|: columns against rows, independent per column
  double hmax = 0.0, asym = 0.0;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double* col = p.H.data() + j * n;
    double cmax = 0.0, amax = 0.0;
    for (Eigen::Index i = j; i < n; ++i) {
      cmax = std::max(cmax, std::fabs(col[i]));
      amax = std::max(amax, std::fabs(col[i] - p.H(j, i)));
    }
    hmax = std::max(hmax, cmax);
    asym = std::max(asym, amax);
  }
  if (asym > 1e-10 * hmax) return false;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (std::isnan(p.lb(i)) || std::isnan(p.ub(i)) || p.lb(i) > p.ub(i)) return false;
    if (p.lb(i) == kInf || p.ub(i) == -kInf) return false;
  }
  for (Eigen::Index k = 0; k < m; ++k) {
    if (std::isnan(p.lbA(k)) || std::isnan(p.ubA(k)) || p.lbA(k) > p.ubA(k)) return false;
    if (p.lbA(k) == kInf || p.ubA(k) == -kInf) return false;
  }
  return true;
}

Solver::Solver(const Settings& settings)
    : settings_(settings), ws_(std::make_unique<internal::Workspace>()) {
#if defined(HYQ_NAN_INIT)
  // debug builds: every floating-point workspace entry starts as NaN, so that a read before a
  // write shows in the results (house style §4)
  internal::Workspace& w = *ws_;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (auto* a : {&w.chol, &w.linv, &w.linvt, &w.mw, &w.lw, &w.square, &w.h_copy})
    a->fill(nan);
  for (auto* a : {&w.xk, &w.q, &w.v, &w.u, &w.delta, &w.lambda, &w.lambda_star, &w.d, &w.dw,
                  &w.dw_inv, &w.mnew, &w.kvec, &w.tmp, &w.tmp2})
    a->fill(nan);
  for (auto* a : {&w.lo, &w.hi, &w.cx, &w.cdelta, &w.cert, &w.lo_scale, &w.hi_scale,
                  &w.lo_finite, &w.hi_finite, &w.entry_violation, &w.warm_y})
    a->fill(nan);
  w.a_copy.fill(nan);
#endif
}
Solver::~Solver() = default;
Solver::Solver(Solver&&) noexcept = default;
Solver& Solver::operator=(Solver&&) noexcept = default;

Status Solver::Solve(const Problem& p, const Budget& budget, Solution* sol) noexcept {
  const Clock::time_point t0 = Clock::now();
  Workspace& ws = *ws_;
  const int n = static_cast<int>(p.H.rows()), m = static_cast<int>(p.A.rows());
  const bool warm = budget.warm_start && sol->x.size() == n && sol->y_bounds.size() == n &&
                    sol->y_constraints.size() == m && sol->status != Status::kBadInput;
  // keep the warm start (previous x, side and signed multiplier per row) before *sol is reset
  if (warm) {
    auto side_of = [](Active a) -> std::int8_t {
      return a == Active::kUpper ? 1 : a == Active::kLower ? -1 : a == Active::kEquality ? 2 : 0;
    };
    for (int i = 0; i < n; ++i) {
      ws.xk[i] = sol->x(i);
      ws.warm_side[i] = side_of(sol->active_bounds[i]);
      ws.warm_y[i] = sol->y_bounds(i);
    }
    for (int k = 0; k < m; ++k) {
      ws.warm_side[n + k] = side_of(sol->active_constraints[k]);
      ws.warm_y[n + k] = sol->y_constraints(k);
    }
  }
  SizeSolution(sol, n, m);
  sol->iterations = 0;
  sol->outer_iterations = 0;
  sol->objective = 0.0;
  sol->regularisation = 0.0;
  sol->kkt = KktResiduals{};
  auto finish = [&](Status status) {
    sol->status = status;
    sol->solve_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
    return status;
  };
  if (!IsWellFormed(p)) return finish(Status::kBadInput);

  // a warm start with the very same H and A keeps L and the working set of the last solve
  const bool same_matrices =
      warm && ws.factor_valid && ws.factor_n == n && ws.factor_m == m &&
      std::memcmp(ws.h_copy.data(), p.H.data(), sizeof(double) * n * n) == 0 &&
      (m == 0 || std::memcmp(ws.a_copy.data(), p.A.data(), sizeof(double) * m * n) == 0);

  ws.problem = &p;
  ws.products_valid = false;
  ws.n = n;
  ws.m = m;
  ws.rows = n + m;
  bool equalities_changed = false;
  for (int i = 0; i < ws.rows; ++i) {
    const double lo = i < n ? p.lb(i) : p.lbA(i - n);
    const double hi = i < n ? p.ub(i) : p.ubA(i - n);
    ws.lo[i] = lo;
    ws.hi[i] = hi;
    const std::uint8_t eq = lo == hi;
    equalities_changed = equalities_changed || (eq != ws.is_eq[i] && ws.pos_of[i] >= 0);
    ws.is_eq[i] = eq;
    // the scales are a function of the bound alone: divide only for a bound that changed
    const double lo_finite = std::max(lo, -1e300), hi_finite = std::min(hi, 1e300);
    if (!(lo_finite == ws.lo_finite[i])) {
      ws.lo_finite[i] = lo_finite;
      ws.lo_scale[i] = 1.0 / (1.0 + std::fabs(lo_finite));
    }
    if (!(hi_finite == ws.hi_finite[i])) {
      ws.hi_finite[i] = hi_finite;
      ws.hi_scale[i] = 1.0 / (1.0 + std::fabs(hi_finite));
    }
  }
  ws.hmax = 0.0;
  for (int i = 0; i < n; ++i) ws.hmax = std::max(ws.hmax, p.H(i, i));
  // proximal centre: the previous answer, or 0, clipped into the bounds
  for (int i = 0; i < n; ++i) {
    const double x0 = warm ? ws.xk[i] : 0.0;
    ws.xk[i] = std::clamp(x0, p.lb(i), p.ub(i));
  }
  const double eps_floor = kMinRelativeEps * (ws.hmax > 0.0 ? ws.hmax : 1.0);

  const bool keep = same_matrices && !equalities_changed;
  if (keep) {
    // rows whose active side became infinite leave W
    for (int q = ws.nw - 1; q >= 0; --q) {
      const int row = ws.w_row[q];
      const double bound = ws.w_sign[q] > 0 ? ws.hi[row] : ws.lo[row];
      if (!std::isfinite(bound)) internal::RemoveFromWorkingSet(&ws, q);
    }
    Linearise(&ws);
    internal::RefreshRightHandSides(&ws);
  } else {
    // H + εI = L Lᵀ with ε = 0 when H is safely positive definite
    ws.factor_valid = false;
    ws.eps = 0.0;
    if (settings_.singular_hessian || !internal::FactorHessian(&ws, 0.0, kPositiveDefiniteFloor)) {
      ws.eps = settings_.proximal_weight * (ws.hmax > 0.0 ? ws.hmax : 1.0);
      if (!internal::FactorHessian(&ws, ws.eps, 0.0)) return finish(Status::kBadInput);
    }
    std::memcpy(ws.h_copy.data(), p.H.data(), sizeof(double) * n * n);
    if (m > 0) std::memcpy(ws.a_copy.data(), p.A.data(), sizeof(double) * m * n);
    ws.factor_valid = true;
    ws.factor_n = n;
    ws.factor_m = m;
    Linearise(&ws);
    for (int i = 0; i < ws.rows; ++i) ws.pos_of[i] = -1;
    ws.nw = 0;
    for (int i = 0; warm && i < ws.rows; ++i) {
      const int side = ws.warm_side[i];
      if (side == 0 || (side == 2 && !ws.is_eq[i])) continue;  // (no longer an equality)
      const double y = ws.warm_y[i];
      const int sign = side == 2 ? (y < 0.0 ? -1 : 1) : side;
      if (!std::isfinite(sign > 0 ? ws.hi[i] : ws.lo[i])) continue;
      internal::AppendIfIndependent(&ws, i, sign, std::max(0.0, sign * y),
                                    settings_.dependence_tolerance);
    }
  }

  internal::InnerLimits limits;
  limits.has_deadline = budget.deadline.has_value();
  if (limits.has_deadline) limits.deadline = *budget.deadline;
  limits.primal_tolerance = settings_.primal_tolerance;
  limits.dependence_tolerance = settings_.dependence_tolerance;

  int iterations = 0;
  double step_prev = 0.0;
  bool have_iterate = false;
  Status status = Status::kIterationLimit;
  for (int outer = 0;; ++outer) {
    if (outer > 0) {
      Linearise(&ws);
      internal::RefreshRightHandSides(&ws);
    }
    // the subproblem: active-set iterations, then (when the KKT check fails, i.e. the rounding of
    // an ill-conditioned H + εI shows) refinement on W; a row outside W that the refined step
    // violates sends the active-set iteration on from there
    int inner = 0;
    bool scan_first = false, stop = false;
    for (int pass = 0;; ++pass) {
      int used = 0;
      limits.max_iterations = budget.max_iterations - iterations - inner;
      const InnerStatus inner_status = internal::SolveSubproblem(&ws, limits, &used, scan_first);
      inner += used;
      sol->iterations = iterations + inner + 1;
      sol->outer_iterations = outer + 1;
      sol->regularisation = ws.eps;
      if (inner_status == InnerStatus::kInfeasible) {
        // the certificate, normalised to ‖w‖∞ = 1, in place of the multipliers
        const double wmax = std::max(MaxAbs(ws.cert.data(), ws.rows), 1e-300);
        for (int i = 0; i < n; ++i) {
          sol->x(i) = ws.xk[i];
          sol->y_bounds(i) = ws.cert[i] / wmax;
        }
        for (int k = 0; k < m; ++k) sol->y_constraints(k) = ws.cert[n + k] / wmax;
        ws.products_valid = false;  // x is not the iterate they belong to
        status = Status::kInfeasible;
        stop = true;
        break;
      }
      if (inner_status != InnerStatus::kOptimal) {
        status = inner_status == InnerStatus::kDeadline ? Status::kDeadline
                                                        : Status::kIterationLimit;
        if (!have_iterate) {
          internal::ComputeStep(&ws);
          WriteIterate(ws, sol);
          sol->kkt = ComputeKktResiduals(p, sol->x, sol->y_bounds, sol->y_constraints);
        }
        stop = true;
        break;
      }
      WriteIterate(ws, sol);
      have_iterate = true;
      sol->kkt = CheckIterate(&ws, *sol);
      if (sol->kkt.max() <= settings_.kkt_tolerance || pass >= kMaxRefinements) break;
      // with ε > 0 stationarity includes the proximal term ε δ, which the next outer iteration
      // removes; refinement is for the rows (primal, complementarity) or for ε = 0
      const double tol = settings_.kkt_tolerance;
      if (sol->kkt.primal <= tol && sol->kkt.complementarity <= tol && sol->kkt.dual <= tol &&
          (ws.eps > 0.0 || sol->kkt.stationarity <= tol))
        break;
      internal::RefineOnWorkingSet(&ws);
      WriteIterate(ws, sol);
      sol->kkt = CheckIterate(&ws, *sol);
      if (sol->kkt.max() <= settings_.kkt_tolerance) break;
      internal::ComputeRowSteps(&ws);
      scan_first = true;
    }
    iterations += inner + 1;
    if (stop) break;
    if (sol->kkt.max() <= settings_.kkt_tolerance) {
      status = Status::kOptimal;
      break;
    }
    if (ws.eps > 0.0 && IsRay(ws, sol->direction.data())) {
      status = Status::kUnbounded;
      break;
    }
    sol->direction.setZero();
    if (outer + 1 >= settings_.max_outer_iterations || iterations >= budget.max_iterations) {
      status = Status::kIterationLimit;
      break;
    }
    if (limits.has_deadline && limits.deadline.Passed()) {
      status = Status::kDeadline;
      break;
    }
    // the next proximal centre is this iterate
    const double step = MaxAbs(ws.delta.data(), n);
    for (int i = 0; i < n; ++i) ws.xk[i] += ws.delta[i];
    // slow linear convergence (small curvature against ε on the active face): smaller ε
    // (or, when the active set still changes, when the steps hardly shrink at all)
    if (ws.eps > eps_floor && outer > 0 &&
        ((inner == 0 && step > 0.25 * step_prev) || (outer > 2 && step > 0.5 * step_prev))) {
      const double eps_new = std::max(eps_floor, ws.eps * kEpsReduction);
      if (internal::FactorHessian(&ws, eps_new, 0.0)) {
        ws.eps = eps_new;
        internal::RebuildWorkingSet(&ws, settings_.dependence_tolerance);
      } else {
        internal::FactorHessian(&ws, ws.eps, 0.0);
      }
    }
    step_prev = step;
  }
  // H x from the last KKT check when it was made at this x
  sol->objective = ws.products_valid ? ObjectiveFromProducts(p, sol->x, ws.kkt_hx.data())
                                     : Objective(p, sol->x);
  // finite data can still overflow (H = diag(1e308), g = 1e308): an x the caller would use must
  // be finite, else the data were unusable
  if (status != Status::kInfeasible &&
      !(AllFinite(sol->x.data(), n) && std::isfinite(sol->objective)))
    status = Status::kBadInput;
  return finish(status);
}

}  // namespace hyq::qp
