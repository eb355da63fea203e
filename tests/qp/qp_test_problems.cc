#include "tests/qp/qp_test_problems.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include <Eigen/Dense>

namespace hyq::qp::testing {
namespace {

double Uniform(double a, double b, std::mt19937_64* rng) {
  return std::uniform_real_distribution<double>(a, b)(*rng);
}

Eigen::MatrixXd Gaussian(int rows, int cols, std::mt19937_64* rng) {
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::MatrixXd M(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) M(i, j) = N(*rng);
  return M;
}

}  // namespace

MatrixH RandomHessian(int n, double condition, int rank, std::mt19937_64* rng) {
  if (rank < 0 || rank > n) rank = n;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(Gaussian(n, n, rng));
  const Eigen::MatrixXd Q = qr.householderQ();
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < rank; ++i) {
    const double t = rank > 1 ? static_cast<double>(i) / (rank - 1) : 0.0;
    d(i) = std::pow(condition, -t);
  }
  const Eigen::MatrixXd H = Q * d.asDiagonal() * Q.transpose();
  MatrixH out = 0.5 * (H + H.transpose());
  return out;
}

Planted MakePlanted(const PlantedOptions& o, std::mt19937_64* rng) {
  const int n = o.n, m = o.m;
  Planted t;
  Problem& p = t.problem;
  p.Resize(n, m);
  p.H = RandomHessian(n, o.condition, o.rank, rng);
  if (m > 0) p.A = Gaussian(m, n, rng);
  t.x.resize(n);
  for (int i = 0; i < n; ++i) t.x(i) = Uniform(-1, 1, rng);
  t.y_bounds.setZero(n);
  t.y_constraints.setZero(m);
  t.active_bounds.fill(Active::kInactive);
  t.active_constraints.fill(Active::kInactive);

  std::vector<int> bi(n), ci(m);
  std::iota(bi.begin(), bi.end(), 0);
  std::iota(ci.begin(), ci.end(), 0);
  std::shuffle(bi.begin(), bi.end(), *rng);
  std::shuffle(ci.begin(), ci.end(), *rng);
  auto inactive_side = [&](double value, double dir) {
    return Uniform(0, 1, rng) < o.infinite_fraction ? dir * kInf : value + dir * Uniform(0.1, 2, rng);
  };
  // one row lo ≤ v ≤ hi: active (an equality, or a random side whose multiplier y has its sign)
  // or inactive on both sides
  auto plant_row = [&](double v, bool active, bool equality, double* lo, double* hi,
                       double* y) {
    if (!active) {
      *lo = inactive_side(v, -1);
      *hi = inactive_side(v, 1);
      return Active::kInactive;
    }
    const bool upper = Uniform(0, 1, rng) < 0.5;
    const double multiplier = Uniform(0.5, 2, rng);
    *y = upper ? multiplier : -multiplier;
    if (equality) {
      *lo = *hi = v;
      return Active::kEquality;
    }
    *hi = upper ? v : inactive_side(v, 1);
    *lo = upper ? inactive_side(v, -1) : v;
    return upper ? Active::kUpper : Active::kLower;
  };
  for (int r = 0; r < n; ++r) {
    const int i = bi[r];
    t.active_bounds[i] = plant_row(t.x(i), r < o.active_bounds, /*equality=*/false, &p.lb(i),
                                   &p.ub(i), &t.y_bounds(i));
  }
  const Eigen::VectorXd ax = p.A * t.x;
  for (int r = 0; r < m; ++r) {
    const int k = ci[r];
    t.active_constraints[k] = plant_row(ax(k), r < o.active_constraints, r < o.equalities,
                                        &p.lbA(k), &p.ubA(k), &t.y_constraints(k));
  }
  p.g = -(p.H * t.x) - t.y_bounds;
  if (m > 0) p.g -= p.A.transpose() * t.y_constraints;
  return t;
}

Problem MakeIdShaped(int feet, std::mt19937_64* rng) {
  const int nz = 5 * feet;
  // base inertia-like SPD 6 × 6, Z 6 × nz (rank 6), p the free base velocity
  const Eigen::MatrixXd G = Gaussian(6, 6, rng);
  const Eigen::MatrixXd Mb = G * G.transpose() + 6.0 * Eigen::MatrixXd::Identity(6, 6);
  const Eigen::MatrixXd Z = 0.05 * Gaussian(6, nz, rng);
  const Eigen::VectorXd pvec = 0.3 * Gaussian(6, 1, rng);
  Problem p;
  const int m = 2 * feet;
  p.Resize(nz, m);
  const Eigen::MatrixXd H = Z.transpose() * Mb * Z;
  p.H = 0.5 * (H + H.transpose());
  p.g = Z.transpose() * Mb * pvec;
  p.lb.setZero();  // impulses ≥ 0
  // friction: μ c_N − Σ c_D ≥ 0 per foot
  for (int f = 0; f < feet; ++f) {
    const double mu = Uniform(0.1, 1.0, rng);
    p.A(f, 5 * f) = mu;
    for (int k = 1; k < 5; ++k) p.A(f, 5 * f + k) = -1.0;
    p.lbA(f) = 0.0;
  }
  // non-penetration: the normal velocity of each foot, n_fᵀ (Z z + p) ≥ 0, kept feasible at a
  // z0 inside the friction pyramids
  Eigen::VectorXd z0 = Eigen::VectorXd::Zero(nz);
  for (int f = 0; f < feet; ++f) {
    z0(5 * f) = Uniform(0.5, 1.5, rng);
    for (int k = 1; k < 5; ++k) z0(5 * f + k) = 0.02 * Uniform(0.0, 1.0, rng);
  }
  for (int f = 0; f < feet; ++f) {
    const Eigen::MatrixXd nrow = Gaussian(1, 6, rng);
    p.A.row(feet + f) = nrow * Z;
    p.lbA(feet + f) = std::min(-(nrow * pvec)(0), (nrow * Z * z0)(0));
  }
  return p;
}

Problem MakeRandomStrictlyConvex(int n, int m, double condition, std::mt19937_64* rng) {
  Problem p;
  p.Resize(n, m);
  p.H = RandomHessian(n, condition, n, rng);
  p.g = Gaussian(n, 1, rng);
  p.A = Gaussian(m, n, rng);
  const Eigen::VectorXd x0 = 0.5 * Gaussian(n, 1, rng);
  const Eigen::VectorXd ax = p.A * x0;
  for (int k = 0; k < m; ++k) p.ubA(k) = ax(k) + Uniform(0.0, 1.0, rng);
  p.g *= 5.0;
  return p;
}

void Perturb(double relative, bool move_g, std::mt19937_64* rng, Problem* p) {
  std::normal_distribution<double> N(0.0, relative);
  const double gs = std::max(1.0, p->g.cwiseAbs().maxCoeff());
  for (int i = 0; move_g && i < p->n(); ++i) p->g(i) += gs * N(*rng);
  for (int k = 0; k < p->m(); ++k) {
    const double shift = N(*rng);
    if (std::isfinite(p->lbA(k))) p->lbA(k) += shift;
    if (std::isfinite(p->ubA(k))) p->ubA(k) += shift;
  }
}

::testing::AssertionResult IsFarkasCertificate(const Problem& p, const Solution& s) {
  const int n = p.n(), m = p.m();
  Eigen::VectorXd r = s.y_constraints.size() > 0 && m > 0
                          ? Eigen::VectorXd(p.A.transpose() * s.y_constraints)
                          : Eigen::VectorXd::Zero(n);
  double wmax = s.y_bounds.cwiseAbs().maxCoeff();
  if (m > 0) wmax = std::max(wmax, s.y_constraints.cwiseAbs().maxCoeff());
  if (!(wmax > 0.0)) return ::testing::AssertionFailure() << "certificate is zero";
  // every x satisfying the rows has  rᵀx = w_cᵀ A x ≤ β_c  and  w_bᵀ x ≤ β_b
  double beta = 0.0, scale = 0.0;
  for (int i = 0; i < n + m; ++i) {
    const double w = i < n ? s.y_bounds(i) : s.y_constraints(i - n);
    const double lo = i < n ? p.lb(i) : p.lbA(i - n);
    const double hi = i < n ? p.ub(i) : p.ubA(i - n);
    if (w == 0.0) continue;
    const double b = w > 0 ? hi : lo;
    if (!std::isfinite(b))
      return ::testing::AssertionFailure() << "weight " << w << " on an infinite side, row " << i;
    beta += w * b;
    scale = std::max(scale, std::fabs(w * b));
  }
  // so (r + w_b)ᵀ x ≤ β with β = β_b + β_c; r + w_b = 0 gives 0 ≤ β, a contradiction when β < 0.
  // A rounding-size residual e = r + w_b is allowed where the bounds are finite: then
  // eᵀx ≥ Σ min(e_i lb_i, e_i ub_i) =: low, and low > β is the contradiction.
  const double amax = m > 0 ? std::max(1.0, p.A.cwiseAbs().maxCoeff()) : 1.0;
  double low = 0.0, emax = 0.0;
  for (int i = 0; i < n; ++i) {
    const double e = r(i) + s.y_bounds(i);
    emax = std::max(emax, std::fabs(e));
    if (std::fabs(e) <= 1e-13 * wmax * amax) continue;
    const double b = e > 0 ? p.lb(i) : p.ub(i);
    if (!std::isfinite(b))
      return ::testing::AssertionFailure() << "residual " << e << " on an unbounded variable " << i;
    low += e * b;
  }
  if (!(beta - low < -1e-9 * std::max(1.0, scale)))
    return ::testing::AssertionFailure() << "no contradiction: beta " << beta << ", low " << low;
  if (!(emax <= 1e-6 * wmax * amax))
    return ::testing::AssertionFailure() << "|y_b + A' y_c| = " << emax;
  return ::testing::AssertionSuccess() << "residual " << emax / (wmax * amax);
}

}  // namespace hyq::qp::testing
