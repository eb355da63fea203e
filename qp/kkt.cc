// KKT residuals of the unregularised problem (definitions in qp/problem.h), plus the small
// helpers of problem.h.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "qp/problem.h"
#include "qp/workspace.h"

namespace hyq::qp {

using internal::Dot;

void Problem::Resize(int n, int m) noexcept {
  SetSizes(n, m);
  H.setZero();
  g.setZero();
  A.setZero();
}

void Problem::SetSizes(int n, int m) noexcept {
  n = std::clamp(n, 0, kMaxVariables);
  m = std::clamp(m, 0, kMaxConstraints);
  H.resize(n, n);
  g.resize(n);
  lb.setConstant(n, -kInf);
  ub.setConstant(n, kInf);
  A.resize(m, n);
  lbA.setConstant(m, -kInf);
  ubA.setConstant(m, kInf);
}

const char* ToString(Status status) noexcept {
  switch (status) {
    case Status::kOptimal: return "optimal";
    case Status::kInfeasible: return "infeasible";
    case Status::kUnbounded: return "unbounded";
    case Status::kIterationLimit: return "iteration_limit";
    case Status::kDeadline: return "deadline";
    case Status::kBadInput: return "bad_input";
  }
  return "unknown";
}

double KktResiduals::max() const noexcept {
  // std::max drops a NaN (it compares false), which would then pass for a small residual
  if (std::isnan(stationarity + primal + dual + complementarity))
    return std::numeric_limits<double>::quiet_NaN();
  return std::max({stationarity, primal, dual, complementarity});
}

KktResiduals ComputeKktResiduals(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                                 const VectorM& y_constraints) noexcept {
  std::array<double, kMaxVariables> hx;
  std::array<double, kMaxConstraints> ax;
  return internal::KktResidualsAndProducts(p, x, y_bounds, y_constraints, hx.data(), ax.data());
}

namespace internal {

namespace {

// support: the rows (0..n+m−1, bounds first) outside which both multiplier vectors are zero, or
// nullptr (any y). With a support, Aᵀy, the multipliers' sizes, complementarity and dual
// feasibility are summed over it alone.
template <int N>
KktResiduals Residuals(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                       const VectorM& y_constraints, double* hx_out, double* ax,
                       const int* support, int support_size) noexcept {
  const int n = N > 0 ? N : p.n(), m = p.m();
  const double* H = p.H.data();
  const double* A = p.A.data();
  // A x four columns per pass (contiguous)
  MultiplyA<N>(p, x.data(), ax);
  double aty[kMaxVariables];
  if (support) {
    for (int i = 0; i < n; ++i) aty[i] = 0.0;
    for (int s = 0; s < support_size; ++s) {
      const int k = support[s] - n;
      if (k < 0) continue;
      const double y = y_constraints(k);
      for (int j = 0; j < n; ++j) aty[j] += A[k + j * m] * y;
    }
  } else {
    // column i of A: contiguous
    for (int i = 0; i < n; ++i) aty[i] = Dot(A + i * m, y_constraints.data(), m);
  }
  double hx_max = 0, g_max = 0, yb_max = 0, aty_max = 0, stat = 0, x_max = 0;
  for (int i = 0; i < n; ++i) {
    // row i of H is its column i (H symmetric)
    const double hx = Dot(H + i * n, x.data(), n);
    hx_out[i] = hx;
    hx_max = std::max(hx_max, std::fabs(hx));
    g_max = std::max(g_max, std::fabs(p.g(i)));
    aty_max = std::max(aty_max, std::fabs(aty[i]));
    stat = std::max(stat, std::fabs(hx + p.g(i) + y_bounds(i) + aty[i]));
    x_max = std::max(x_max, std::fabs(x(i)));
  }
  double ax_max = 0, primal = 0;
  for (int i = 0; i < n; ++i) primal = std::max({primal, x(i) - p.ub(i), p.lb(i) - x(i)});
  for (int k = 0; k < m; ++k) {
    ax_max = std::max(ax_max, std::fabs(ax[k]));
    primal = std::max({primal, ax[k] - p.ubA(k), p.lbA(k) - ax[k]});
  }
  double y_max = 0, dual = 0, compl_ = 0;
  auto row = [&](double value, double lo, double hi, double y) {
    y_max = std::max(y_max, std::fabs(y));
    if (y > 0) {
      if (hi < kInf) compl_ = std::max(compl_, y * std::fabs(hi - value));
      else dual = std::max(dual, y);
    } else if (y < 0) {
      if (lo > -kInf) compl_ = std::max(compl_, -y * std::fabs(value - lo));
      else dual = std::max(dual, -y);
    }
  };
  auto row_at = [&](int r) {
    if (r < n) row(x(r), p.lb(r), p.ub(r), y_bounds(r));
    else row(ax[r - n], p.lbA(r - n), p.ubA(r - n), y_constraints(r - n));
  };
  if (support) {
    for (int s = 0; s < support_size; ++s) row_at(support[s]);
  } else {
    for (int r = 0; r < n + m; ++r) row_at(r);
  }
  for (int i = 0; i < n; ++i) yb_max = std::max(yb_max, std::fabs(y_bounds(i)));
  const double value_scale = std::max({1.0, x_max, ax_max});
  KktResiduals r;
  r.stationarity = stat / std::max({1.0, hx_max, g_max, yb_max, aty_max});
  r.primal = primal / value_scale;
  r.dual = dual / std::max(1.0, y_max);
  r.complementarity = compl_ / (std::max(1.0, y_max) * value_scale);
  return r;
}

}  // namespace

KktResiduals KktResidualsAndProducts(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                                     const VectorM& y_constraints, double* hx_out, double* ax,
                                     const int* support, int support_size) noexcept {
  return WithSize(p.n(), [&](auto n) {
    return Residuals<n()>(p, x, y_bounds, y_constraints, hx_out, ax, support, support_size);
  });
}

}  // namespace internal

}  // namespace hyq::qp
