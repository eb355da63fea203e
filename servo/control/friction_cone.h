// The friction cone of the two-stage ID (Zapolsky et al. eq 30): per stance contact i the
// inscribed pyramid of its r tangent directions,
//   μ_i c_N,i − Σ_k c_D,ik ≥ 0                                                         (30)
// as a row over the impulses z = [c_N; c_D] (servo/control/contact_model.h). A contact with
// μ_i at or below the frictionless threshold has no friction: its tangential impulses are fixed at
// 0 instead (its row would only squeeze them through nearly dependent rows).
#pragma once

#include <Eigen/Core>

#include "servo/control/contact_model.h"

namespace hyq::servo {

/// Whether contact i is treated as frictionless.
inline bool Frictionless(const ContactSet& set, int i, double frictionless_mu) noexcept {
  return set.mu[i] <= frictionless_mu;
}

/// Row i of (30) over z: μ_i at c_N,i, −1 at each c_D,ik, 0 elsewhere (`row` has num_impulses()
/// entries and is overwritten).
template <class Row>
void FrictionConeRow(const ContactSet& set, int i, Row&& row) noexcept {
  row.setZero();
  row(set.NormalIndex(i)) = set.mu[i];
  for (int k = 0; k < set.tangents; ++k) row(set.TangentIndex(i, k)) = -1.0;
}

/// The same row applied to the columns of P (Stage II's w coordinates, z = z_I + P w):
/// μ_i P(c_N,i, :) − Σ_k P(c_D,ik, :).
template <class Mat, class Row>
void FrictionConeRowOf(const ContactSet& set, int i, const Mat& P, Row&& row) noexcept {
  row = set.mu[i] * P.row(set.NormalIndex(i));
  for (int k = 0; k < set.tangents; ++k) row -= P.row(set.TangentIndex(i, k));
}

/// The slack of (30) at z: μ_i z_N,i − Σ_k z_D,ik (≥ 0 inside the pyramid).
template <class Vec>
double FrictionConeSlack(const ContactSet& set, int i, const Vec& z) noexcept {
  double slack = set.mu[i] * z(set.NormalIndex(i));
  for (int k = 0; k < set.tangents; ++k) slack -= z(set.TangentIndex(i, k));
  return slack;
}

}  // namespace hyq::servo
