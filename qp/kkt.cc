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

template <int N>
KktResiduals Residuals(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                       const VectorM& y_constraints, double* hx_out, double* ax) noexcept {
  const int n = N > 0 ? N : p.n(), m = p.m();
  const double* H = p.H.data();
  const double* A = p.A.data();
  // A x four columns per pass (contiguous), then everything in one pass per row
  MultiplyA<N>(p, x.data(), ax);
  double hx_max = 0, g_max = 0, yb_max = 0, aty_max = 0, stat = 0, x_max = 0;
  for (int i = 0; i < n; ++i) {
    // row i of H is its column i (H symmetric); Aᵀy takes column i of A: both contiguous
    const double hx = Dot(H + i * n, x.data(), n);
    hx_out[i] = hx;
    const double aty = Dot(A + i * m, y_constraints.data(), m);
    hx_max = std::max(hx_max, std::fabs(hx));
    g_max = std::max(g_max, std::fabs(p.g(i)));
    yb_max = std::max(yb_max, std::fabs(y_bounds(i)));
    aty_max = std::max(aty_max, std::fabs(aty));
    stat = std::max(stat, std::fabs(hx + p.g(i) + y_bounds(i) + aty));
    x_max = std::max(x_max, std::fabs(x(i)));
  }
  double y_max = yb_max, ax_max = 0;
  for (int k = 0; k < m; ++k) {
    y_max = std::max(y_max, std::fabs(y_constraints(k)));
    ax_max = std::max(ax_max, std::fabs(ax[k]));
  }
  double primal = 0, dual = 0, compl_ = 0;
  auto row = [&](double value, double lo, double hi, double y) {
    primal = std::max({primal, value - hi, lo - value});
    if (y > 0) {
      if (hi < kInf) compl_ = std::max(compl_, y * std::fabs(hi - value));
      else dual = std::max(dual, y);
    } else if (y < 0) {
      if (lo > -kInf) compl_ = std::max(compl_, -y * std::fabs(value - lo));
      else dual = std::max(dual, -y);
    }
  };
  for (int i = 0; i < n; ++i) row(x(i), p.lb(i), p.ub(i), y_bounds(i));
  for (int k = 0; k < m; ++k) row(ax[k], p.lbA(k), p.ubA(k), y_constraints(k));
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
                                     const VectorM& y_constraints, double* hx_out,
                                     double* ax) noexcept {
  return WithSize(p.n(), [&](auto n) {
    return Residuals<n()>(p, x, y_bounds, y_constraints, hx_out, ax);
  });
}

}  // namespace internal

}  // namespace hyq::qp
