#include "tools/loop_model/rational_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/QR>

namespace hyq::loop_model {
namespace {

// B(w) / A(w) with w = z⁻¹ as a ratio of polynomials in z: both × z^n, n = max(nb, na)
TransferFunction InZ(const Eigen::VectorXd& b, const Eigen::VectorXd& a, int n) {
  Polynomial num(static_cast<std::size_t>(n) + 1, 0.0), den(static_cast<std::size_t>(n) + 1, 0.0);
  for (Eigen::Index i = 0; i < b.size(); ++i) num[static_cast<std::size_t>(n - i)] = b(i);
  den[static_cast<std::size_t>(n)] = 1.0;
  for (Eigen::Index i = 0; i < a.size(); ++i) den[static_cast<std::size_t>(n - 1 - i)] = a(i);
  return TransferFunction(num, den);
}

}  // namespace

RationalFit FitRational(const std::vector<ResponsePoint>& points, double period_s, int n,
                        int iterations) {
  const int k_count = static_cast<int>(points.size());
  if (n < 0 || k_count < n + 1)
    throw std::invalid_argument("rational fit: expected at least " + std::to_string(n + 1) +
                                " points for order " + std::to_string(n) + ", found " +
                                std::to_string(k_count));
  const auto K = static_cast<std::size_t>(k_count);
  std::vector<std::complex<double>> w(K);
  for (std::size_t k = 0; k < K; ++k)
    w[k] = std::polar(1.0, -2.0 * std::numbers::pi * points[k].f_hz * period_s);
  // A(w) at the points, from its coefficients a (a_0 = 1)
  auto eval = [&](const Eigen::VectorXd& c, std::size_t k) {
    std::complex<double> v = 0.0, wi = 1.0;
    for (Eigen::Index i = 0; i < c.size(); ++i, wi *= w[k]) v += c(i) * wi;
    return v;
  };
  Eigen::VectorXd a = Eigen::VectorXd::Zero(n + 1);
  a(0) = 1.0;
  std::vector<double> weight(K, 1.0);  // 1 / |A_prev(w_k)|
  for (int it = 0; it < iterations && n > 0; ++it) {
    // rows: Re and Im of  [Σ b_i w^i − H Σ_{i≥1} a_i w^i] s_k = H s_k,  s_k = weight_k / |H_k|
    Eigen::MatrixXd Mx(2 * k_count, 2 * n + 1);
    Eigen::VectorXd rhs(2 * k_count);
    for (std::size_t k = 0; k < K; ++k) {
      const std::complex<double> H = points[k].value;
      const double s = weight[k] / std::max(std::abs(H), 1e-12);
      std::complex<double> wi = 1.0;
      for (int i = 0; i <= n; ++i, wi *= w[k]) {
        Mx(2 * static_cast<Eigen::Index>(k), i) = s * wi.real();
        Mx(2 * static_cast<Eigen::Index>(k) + 1, i) = s * wi.imag();
      }
      wi = w[k];
      for (int i = 0; i < n; ++i, wi *= w[k]) {
        const std::complex<double> c = -H * wi * s;
        Mx(2 * static_cast<Eigen::Index>(k), n + 1 + i) = c.real();
        Mx(2 * static_cast<Eigen::Index>(k) + 1, n + 1 + i) = c.imag();
      }
      rhs(2 * static_cast<Eigen::Index>(k)) = s * H.real();
      rhs(2 * static_cast<Eigen::Index>(k) + 1) = s * H.imag();
    }
    const Eigen::VectorXd x = Mx.colPivHouseholderQr().solve(rhs);
    a.tail(n) = x.tail(n);
    // the poles (in z: the roots of z^n A(1/z) = Σ a_i z^(n−i)) reflected into the disc of
    // radius kMaxPoleRadius: p → 1 / p̄, then shrunk onto it
    Polynomial zpoly(static_cast<std::size_t>(n) + 1);
    for (int i = 0; i <= n; ++i) zpoly[static_cast<std::size_t>(n - i)] = a(i);
    Eigen::VectorXcd p = Roots(zpoly);
    for (Eigen::Index i = 0; i < p.size(); ++i) {
      if (std::abs(p(i)) > 1.0) p(i) = 1.0 / std::conj(p(i));
      if (std::abs(p(i)) > kMaxPoleRadius) p(i) *= kMaxPoleRadius / std::abs(p(i));
    }
    // A from the poles again: Π (z − p_i) = z^n A(1/z)
    Eigen::VectorXcd c = Eigen::VectorXcd::Zero(n + 1);
    c(0) = 1.0;
    for (Eigen::Index i = 0; i < p.size(); ++i)
      for (Eigen::Index m = i + 1; m >= 1; --m) c(m) -= p(i) * c(m - 1);
    a = c.real();
    for (std::size_t k = 0; k < K; ++k) weight[k] = 1.0 / std::max(std::abs(eval(a, k)), 1e-12);
  }
  // B with A fixed: min Σ |B(w_k)/A(w_k) − H_k|² / |H_k|²  (linear in b)
  Eigen::MatrixXd Mb(2 * k_count, n + 1);
  Eigen::VectorXd rb(2 * k_count);
  for (std::size_t k = 0; k < K; ++k) {
    const std::complex<double> H = points[k].value, A = eval(a, k);
    const double s = 1.0 / std::max(std::abs(H), 1e-12);
    std::complex<double> wi = 1.0;
    for (int i = 0; i <= n; ++i, wi *= w[k]) {
      const std::complex<double> c = s * wi / A;
      Mb(2 * static_cast<Eigen::Index>(k), i) = c.real();
      Mb(2 * static_cast<Eigen::Index>(k) + 1, i) = c.imag();
    }
    rb(2 * static_cast<Eigen::Index>(k)) = s * H.real();
    rb(2 * static_cast<Eigen::Index>(k) + 1) = s * H.imag();
  }
  const Eigen::VectorXd b = Mb.colPivHouseholderQr().solve(rb);
  RationalFit fit{InZ(b, a.tail(n), n), 0.0, 0.0};
  for (std::size_t k = 0; k < K; ++k) {
    const std::complex<double> H = points[k].value;
    const double e = std::abs(fit.model.At(1.0 / w[k]) - H) / std::abs(H);
    fit.max_relative_error = std::max(fit.max_relative_error, e);
    if (points[k].f_hz >= kBandHz[0] && points[k].f_hz <= kBandHz[1])
      fit.band_relative_error = std::max(fit.band_relative_error, e);
  }
  return fit;
}

RationalFit FitBestOrder(const std::vector<ResponsePoint>& points, double period_s, int max_order) {
  std::vector<RationalFit> fits;
  double best = std::numeric_limits<double>::infinity();
  for (int n = 1; n <= max_order; ++n) {
    fits.push_back(FitRational(points, period_s, n));
    best = std::min(best, fits.back().band_relative_error);
  }
  for (const RationalFit& f : fits)
    if (f.band_relative_error <= std::max(1.1 * best, best + kOrderTolerance)) return f;
  return fits.back();
}

}  // namespace hyq::loop_model
