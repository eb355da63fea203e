// Householder QR with column pivoting of a small matrix (at most kRows × kCols, inline storage),
// for the contact ID's rank decisions and its range and complement bases. The factorisation of
// Eigen's ColPivHouseholderQR (the largest remaining column first, reflectors I − τ v vᵀ with
// v(0) = 1 in LAPACK's sign convention, rank = the number of |R_ii| above threshold · max |R_ii|)
// without its dynamic-size machinery, which cost several times the arithmetic on these 12 × 6
// problems. Never allocates.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Core>

namespace hyq::servo {

template <int kRows, int kCols>
class PivotedQr {
 public:
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, kCols, Eigen::ColMajor, kRows, kCols>;

  /// Factors a (a.rows() ≤ kRows). threshold: relative to the largest |R_ii|, as Eigen's
  /// ColPivHouseholderQR::setThreshold.
  void Compute(const Matrix& a, double threshold) noexcept {
    qr_ = a;
    rows_ = static_cast<int>(a.rows());
    size_ = std::min(rows_, kCols);
    // the contact ID's matrices have three rows per foot: those sizes compiled with the row
    // count known (the short loops lose their remainder handling), any other at run time
    switch (rows_) {
      case 3: return Factor<std::min(3, kRows)>(threshold);
      case 6: return Factor<std::min(6, kRows)>(threshold);
      case 9: return Factor<std::min(9, kRows)>(threshold);
      case 12: return Factor<std::min(12, kRows)>(threshold);
      default: return Factor<0>(threshold);
    }
  }

  int rank() const noexcept { return rank_; }
  int rows() const noexcept { return rows_; }
  /// The number of reflectors (min(rows, kCols)).
  int size() const noexcept { return size_; }

  /// x ← Qᵀ x with the first `count` reflectors (x has rows() entries).
  template <class Vec>
  void ApplyQt(Vec&& x, int count) const noexcept {
    for (int k = 0; k < count; ++k) Reflect(k, x);
  }
  /// x ← Q x with the first `count` reflectors.
  template <class Vec>
  void ApplyQ(Vec&& x, int count) const noexcept {
    for (int k = count - 1; k >= 0; --k) Reflect(k, x);
  }

 private:
  // Householder QR with column pivoting of qr_ (rows_ × kCols, column-major with leading
  // dimension rows_) in place; R = rows_ when R > 0 (a case label above kRows cannot match).
  // Plain loops over the storage: at these sizes Eigen's dynamic-size segment reductions cost
  // more than the arithmetic.
  template <int R>
  void Factor(double threshold) noexcept {
    double* q = qr_.data();
    const int m = R > 0 ? R : rows_;
    // squared norms of the columns below row k, downdated after each reflection and computed
    // afresh when cancellation has eaten half the digits (LAPACK's xGEQP3, as Eigen does)
    std::array<double, kCols> norm2, norm2_direct;
    for (int j = 0; j < kCols; ++j) norm2[j] = norm2_direct[j] = SquaredNorm(q + j * m, m);
    constexpr double kRecompute = 1.4901161193847656e-08;  // √ε
    double max_pivot = 0.0;
    for (int k = 0; k < size_; ++k) {
      // the column with the largest norm below row k goes first
      int best = k;
      for (int j = k + 1; j < kCols; ++j)
        if (norm2[j] > norm2[best]) best = j;
      double* ck = q + k * m;
      if (best != k) {
        std::swap_ranges(ck, ck + m, q + best * m);
        std::swap(norm2[k], norm2[best]);
        std::swap(norm2_direct[k], norm2_direct[best]);
      }
      // the reflector that maps column k's part below row k onto β e_k
      const double c0 = ck[k];
      const double tail2 = SquaredNorm(ck + k + 1, m - k - 1);
      double beta = c0;
      tau_[k] = 0.0;
      if (tail2 > std::numeric_limits<double>::min()) {
        beta = std::sqrt(c0 * c0 + tail2);
        if (c0 >= 0.0) beta = -beta;
        const double scale = 1.0 / (c0 - beta);
        for (int i = k + 1; i < m; ++i) ck[i] *= scale;
        tau_[k] = (beta - c0) / beta;
      } else {
        for (int i = k + 1; i < m; ++i) ck[i] = 0.0;
      }
      ck[k] = beta;
      max_pivot = std::max(max_pivot, std::abs(beta));
      for (int j = k + 1; j < kCols; ++j) {
        double* cj = q + j * m;
        double w = cj[k];
        for (int i = k + 1; i < m; ++i) w += ck[i] * cj[i];
        w *= tau_[k];
        cj[k] -= w;
        for (int i = k + 1; i < m; ++i) cj[i] -= w * ck[i];
        norm2[j] -= cj[k] * cj[k];
        if (!(norm2[j] > kRecompute * norm2_direct[j]))
          norm2[j] = norm2_direct[j] = SquaredNorm(cj + k + 1, m - k - 1);
      }
    }
    rank_ = 0;
    for (int i = 0; i < size_; ++i) rank_ += std::abs(qr_(i, i)) > threshold * max_pivot;
  }

  static double SquaredNorm(const double* x, int n) noexcept {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += x[i] * x[i];
    return s;
  }

  template <class Vec>
  void Reflect(int k, Vec& x) const noexcept {
    double w = x(k);
    for (int i = k + 1; i < rows_; ++i) w += qr_(i, k) * x(i);
    w *= tau_[k];
    x(k) -= w;
    for (int i = k + 1; i < rows_; ++i) x(i) -= w * qr_(i, k);
  }

  Matrix qr_;
  std::array<double, kCols> tau_{};
  int rows_ = 0, size_ = 0, rank_ = 0;
};

}  // namespace hyq::servo
