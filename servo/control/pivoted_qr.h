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
    double max_pivot = 0.0;
    for (int k = 0; k < size_; ++k) {
      // the column with the largest norm below row k goes first
      int best = k;
      double best_norm2 = -1.0;
      for (int j = k; j < kCols; ++j) {
        const double n2 = qr_.col(j).segment(k, rows_ - k).squaredNorm();
        if (n2 > best_norm2) best_norm2 = n2, best = j;
      }
      if (best != k) qr_.col(k).swap(qr_.col(best));
      // the reflector that maps column k's part below row k onto β e_k
      const double c0 = qr_(k, k);
      const double tail2 = qr_.col(k).segment(k + 1, rows_ - k - 1).squaredNorm();
      double beta = c0;
      tau_[k] = 0.0;
      if (tail2 > std::numeric_limits<double>::min()) {
        beta = std::sqrt(c0 * c0 + tail2);
        if (c0 >= 0.0) beta = -beta;
        const double scale = 1.0 / (c0 - beta);
        for (int i = k + 1; i < rows_; ++i) qr_(i, k) *= scale;
        tau_[k] = (beta - c0) / beta;
      } else {
        for (int i = k + 1; i < rows_; ++i) qr_(i, k) = 0.0;
      }
      qr_(k, k) = beta;
      max_pivot = std::max(max_pivot, std::abs(beta));
      for (int j = k + 1; j < kCols; ++j) {
        double w = qr_(k, j);
        for (int i = k + 1; i < rows_; ++i) w += qr_(i, k) * qr_(i, j);
        w *= tau_[k];
        qr_(k, j) -= w;
        for (int i = k + 1; i < rows_; ++i) qr_(i, j) -= w * qr_(i, k);
      }
    }
    rank_ = 0;
    for (int i = 0; i < size_; ++i) rank_ += std::abs(qr_(i, i)) > threshold * max_pivot;
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
