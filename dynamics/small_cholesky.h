// Cholesky factorisation and solves for the small symmetric positive-definite matrices of the
// dynamics and the contact ID (3 × 3 leg blocks, 6 × 6 base blocks, the ≤ 12 × 12 contact-space
// matrix J_c M⁻¹ J_cᵀ): plain loops, fixed or dynamic size. Eigen's LLT goes through its
// blocked triangular-solve machinery, which at these sizes costs several times the arithmetic.
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace hyq::dynamics {

/// A = L Lᵀ in place: reads the lower triangle of a (square), overwrites it with L and leaves
/// the strict upper triangle as it was. False when a pivot is not positive (or NaN).
template <class Derived>
bool CholeskyInPlace(Eigen::MatrixBase<Derived>& a) noexcept {
  const Eigen::Index n = a.rows();
  for (Eigen::Index c = 0; c < n; ++c) {
    double d = a(c, c);
    for (Eigen::Index k = 0; k < c; ++k) d -= a(c, k) * a(c, k);
    if (!(d > 0.0)) return false;
    const double lcc = std::sqrt(d);
    const double inv = 1.0 / lcc;
    a(c, c) = lcc;
    for (Eigen::Index r = c + 1; r < n; ++r) {
      double s = a(r, c);
      for (Eigen::Index k = 0; k < c; ++k) s -= a(r, k) * a(c, k);
      a(r, c) = s * inv;
    }
  }
  return true;
}

/// b ← (L Lᵀ)⁻¹ b with L the lower triangle of l (as CholeskyInPlace leaves it).
template <class DerivedL, class DerivedB>
void CholeskySolveInPlace(const Eigen::MatrixBase<DerivedL>& l,
                          Eigen::MatrixBase<DerivedB>& b) noexcept {
  const Eigen::Index n = l.rows();
  for (Eigen::Index c = 0; c < n; ++c) {
    double y = b(c);
    for (Eigen::Index k = 0; k < c; ++k) y -= l(c, k) * b(k);
    b(c) = y / l(c, c);
  }
  for (Eigen::Index c = n - 1; c >= 0; --c) {
    double y = b(c);
    for (Eigen::Index k = c + 1; k < n; ++k) y -= l(k, c) * b(k);
    b(c) = y / l(c, c);
  }
}

/// A⁻¹ = L⁻ᵀ L⁻¹ from the lower triangle of l (fixed size N): W = L⁻¹ by forward substitution
/// on the identity, then the lower triangle of WᵀW, mirrored (exactly symmetric).
template <int N>
void InverseFromCholesky(const Eigen::Matrix<double, N, N>& l,
                         Eigen::Matrix<double, N, N>* out) noexcept {
  Eigen::Matrix<double, N, N> W = Eigen::Matrix<double, N, N>::Zero();
  for (int c = 0; c < N; ++c) {
    W(c, c) = 1.0 / l(c, c);
    for (int r = c + 1; r < N; ++r) {
      double s = 0.0;
      for (int k = c; k < r; ++k) s -= l(r, k) * W(k, c);
      W(r, c) = s / l(r, r);
    }
  }
  for (int c = 0; c < N; ++c)
    for (int r = c; r < N; ++r) {
      double s = 0.0;
      for (int k = r; k < N; ++k) s += W(k, r) * W(k, c);
      (*out)(r, c) = (*out)(c, r) = s;
    }
}

}  // namespace hyq::dynamics
