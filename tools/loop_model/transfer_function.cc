#include "tools/loop_model/transfer_function.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

namespace hyq::loop_model {
namespace {

double MaxAbs(const Polynomial& p) {
  double m = 0.0;
  for (double c : p) m = std::max(m, std::abs(c));
  return m;
}

// the highest-power coefficients that are zero (relative to the largest) dropped
Polynomial Trim(Polynomial p) {
  const double scale = MaxAbs(p);
  while (p.size() > 1 && std::abs(p.back()) <= 1e-14 * scale) p.pop_back();
  return p;
}

}  // namespace

Polynomial Multiply(const Polynomial& a, const Polynomial& b) {
  if (a.empty() || b.empty()) return {0.0};
  Polynomial c(a.size() + b.size() - 1, 0.0);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) c[i + j] += a[i] * b[j];
  return c;
}

Polynomial Add(const Polynomial& a, const Polynomial& b) {
  Polynomial c(std::max(a.size(), b.size()), 0.0);
  for (std::size_t i = 0; i < a.size(); ++i) c[i] += a[i];
  for (std::size_t i = 0; i < b.size(); ++i) c[i] += b[i];
  return c;
}

std::complex<double> Evaluate(const Polynomial& p, std::complex<double> z) {
  std::complex<double> v = 0.0;
  for (std::size_t i = p.size(); i-- > 0;) v = v * z + p[i];
  return v;
}

Eigen::VectorXcd Roots(const Polynomial& p_in) {
  const Polynomial p = Trim(p_in);
  if (MaxAbs(p) == 0.0) throw std::invalid_argument("polynomial roots: the polynomial is zero");
  // roots at z = 0: the zero lowest-power coefficients
  std::size_t zeros = 0;
  while (zeros < p.size() && p[zeros] == 0.0) ++zeros;
  const int n = static_cast<int>(p.size() - 1 - zeros);  // degree of what is left
  Eigen::VectorXcd r(static_cast<Eigen::Index>(n + zeros));
  for (std::size_t i = 0; i < zeros; ++i) r(static_cast<Eigen::Index>(n + i)) = 0.0;
  if (n == 0) return r;
  // companion matrix of the monic polynomial z^n + Σ (c_i / c_n) z^i
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
  const double lead = p.back();
  for (int i = 0; i < n; ++i) C(0, i) = -p[zeros + static_cast<std::size_t>(n - 1 - i)] / lead;
  for (int i = 1; i < n; ++i) C(i, i - 1) = 1.0;
  Eigen::EigenSolver<Eigen::MatrixXd> es(C, false);
  if (es.info() != Eigen::Success)
    throw std::runtime_error("polynomial roots: the eigenvalue iteration did not converge");
  r.head(n) = es.eigenvalues();
  return r;
}

TransferFunction::TransferFunction(Polynomial num, Polynomial den)
    : num_(Trim(std::move(num))), den_(Trim(std::move(den))) {
  if (MaxAbs(den_) == 0.0) throw std::invalid_argument("transfer function: zero denominator");
  if (num_.empty()) num_ = {0.0};
}

TransferFunction TransferFunction::Delay(int m) {
  if (m < 0) throw std::invalid_argument("transfer function: a delay of " + std::to_string(m) +
                                         " samples (expected >= 0)");
  Polynomial den(static_cast<std::size_t>(m) + 1, 0.0);
  den.back() = 1.0;
  return TransferFunction({1.0}, den);
}

std::complex<double> TransferFunction::At(std::complex<double> z) const {
  return Evaluate(num_, z) / Evaluate(den_, z);
}

std::complex<double> TransferFunction::AtAngle(double theta) const {
  return At(std::polar(1.0, theta));
}

TransferFunction TransferFunction::operator*(const TransferFunction& o) const {
  return TransferFunction(Multiply(num_, o.num_), Multiply(den_, o.den_));
}

TransferFunction TransferFunction::operator+(const TransferFunction& o) const {
  // a constant adds without raising the order
  if (o.den_.size() == 1) return TransferFunction(Add(num_, Multiply(den_, {o.num_[0] / o.den_[0]})), den_);
  if (den_.size() == 1) return o + *this;
  return TransferFunction(Add(Multiply(num_, o.den_), Multiply(o.num_, den_)), Multiply(den_, o.den_));
}

StateSpace Realize(const TransferFunction& H) {
  const Polynomial& num = H.num();
  const Polynomial& den = H.den();
  const int n = static_cast<int>(den.size()) - 1;
  if (static_cast<int>(num.size()) - 1 > n)
    throw std::invalid_argument("state-space realisation: an improper transfer function (numerator "
                                "degree " + std::to_string(num.size() - 1) + " > denominator " +
                                std::to_string(n) + ")");
  const double lead = den.back();
  StateSpace ss;
  const double bn = static_cast<int>(num.size()) - 1 == n ? num.back() / lead : 0.0;
  ss.D = bn;
  ss.A = Eigen::MatrixXd::Zero(n, n);
  ss.B = Eigen::VectorXd::Zero(n);
  ss.C = Eigen::RowVectorXd::Zero(n);
  if (n == 0) return ss;
  for (int i = 0; i + 1 < n; ++i) ss.A(i, i + 1) = 1.0;
  for (int i = 0; i < n; ++i) {
    const double d = den[static_cast<std::size_t>(i)] / lead;
    ss.A(n - 1, i) = -d;
    const double b = i < static_cast<int>(num.size()) ? num[static_cast<std::size_t>(i)] / lead : 0.0;
    ss.C(i) = b - bn * d;  // N' = N − b_n D
  }
  ss.B(n - 1) = 1.0;
  return ss;
}

Eigen::VectorXcd Eigenvalues(Eigen::MatrixXd A) {
  const Eigen::Index n = A.rows();
  // radix-2 balancing [Parlett & Reinsch, Numer. Math. 13, 1969; EISPACK balanc]
  constexpr double kRadix = 2.0, kRadix2 = kRadix * kRadix;
  for (bool done = false; !done;) {
    done = true;
    for (Eigen::Index i = 0; i < n; ++i) {
      double c = 0.0, r = 0.0;
      for (Eigen::Index j = 0; j < n; ++j) {
        if (j == i) continue;
        c += std::abs(A(j, i));
        r += std::abs(A(i, j));
      }
      if (c == 0.0 || r == 0.0) continue;
      const double s = c + r;
      double f = 1.0, g = r / kRadix;
      while (c < g) {
        f *= kRadix;
        c *= kRadix2;
      }
      g = r * kRadix;
      while (c > g) {
        f /= kRadix;
        c /= kRadix2;
      }
      if ((c + r) / f < 0.95 * s) {
        done = false;
        A.row(i) /= f;
        A.col(i) *= f;
      }
    }
  }
  Eigen::EigenSolver<Eigen::MatrixXd> es(A, false);
  if (es.info() != Eigen::Success)
    throw std::runtime_error("eigenvalues: the QR iteration did not converge");
  return es.eigenvalues();
}

}  // namespace hyq::loop_model
