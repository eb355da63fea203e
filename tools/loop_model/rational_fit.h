// A discrete-time transfer function fitted to measured frequency-response points, so that a
// measured element (the hydraulic actuator) enters the closed loop's characteristic polynomial:
//   H(z) ≈ B(w) / A(w),  w = z⁻¹,  B = Σ_{i=0..nb} b_i w^i,  A = 1 + Σ_{i=1..na} a_i w^i
// by Sanathanan–Koerner iteration [C. K. Sanathanan, J. Koerner, "Transfer function synthesis
// as a ratio of two complex polynomials", IEEE Trans. Automatic Control 8(1), 1963]: Levy's
// linearised error B(w_k) − H_k A(w_k) [E. C. Levy, IRE Trans. Automatic Control, 1959],
// weighted by 1 / |A_prev(w_k)| (the previous iteration's denominator) so that the iteration
// converges to the output error B/A − H; here also by 1 / |H_k| (a relative error):
//   min Σ_k |B(w_k) − H_k A(w_k)|² / (|A_prev(w_k)|² |H_k|²)   (linear least squares)
// The numerator and denominator have the same order n (the actuator answers within its step).
//
// The poles are kept inside the unit circle: after each step the denominator's roots outside
// it are reflected in (p → 1/p̄) and all shrunk to at most kMaxPoleRadius, as vector fitting
// does [B. Gustavsen, A. Semlyen, "Rational approximation of frequency domain responses by
// vector fitting", IEEE Trans. Power Delivery 14(3), 1999]; the numerator is then fitted with
// the denominator fixed. The actuator's response to the joint's motion is a describing function
// (its amplitude's), which an unconstrained fit explains with a slow pole just outside the
// circle; a loop built from it would be unstable for that reason alone.
// The order: FitBestOrder keeps the lowest whose error in the band that holds the loops'
// crossovers (kBandHz) is within 10 % (or 0.1 percentage point) of the best order's.
#pragma once

#include <vector>

#include "tools/loop_model/frequency_response.h"
#include "tools/loop_model/transfer_function.h"

namespace hyq::loop_model {

inline constexpr double kMaxPoleRadius = 0.995;
inline constexpr double kBandHz[2] = {3.0, 200.0};
inline constexpr double kOrderTolerance = 1e-3;

struct RationalFit {
  TransferFunction model;
  double max_relative_error = 0.0;   // max_k |B/A − H_k| / |H_k| over the points
  double band_relative_error = 0.0;  // the same over the points in kBandHz
};

/// The fit of order n (nb = na = n) to `points` (f in Hz, at sample period T), `iterations` SK
/// steps. Throws std::invalid_argument for fewer points than n + 1.
RationalFit FitRational(const std::vector<ResponsePoint>& points, double period_s, int n,
                        int iterations = 20);

/// Orders 1 to max_order: the lowest whose band error is at most max(1.1 × the least, the least
/// + kOrderTolerance).
RationalFit FitBestOrder(const std::vector<ResponsePoint>& points, double period_s, int max_order);

}  // namespace hyq::loop_model
