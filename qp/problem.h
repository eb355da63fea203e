// The dense convex QP that qp/ solves, and what goes in and comes out of a solve:
//
//   minimise    ½ xᵀ H x + gᵀ x
//   subject to  lb  ≤ x   ≤ ub          (bounds, n rows)
//               lbA ≤ A x ≤ ubA         (general constraints, m rows)
//
// H is symmetric positive semi-definite (singular is fine). A bound may be ±infinity; a row with
// lbA = ubA (or lb = ub) is an equality. Capacities are fixed at compile time and every matrix
// here has inline storage, so filling a Problem each cycle never allocates.
//
// Multiplier convention (one for bounds and constraints): with y_bounds (n) and y_constraints (m),
//   H x + g + y_bounds + Aᵀ y_constraints = 0,
// y_i > 0 only where the upper side is active, y_i < 0 only where the lower side is active.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>

#include <Eigen/Core>

#include "qp/deadline.h"

namespace hyq::qp {

/// Compile-time capacities: HyQ's Stage I has 5 unknowns per foot (20) and one friction and one
/// non-penetration row per foot; 40 / 80 leaves twice the head-room.
inline constexpr int kMaxVariables = 40;
inline constexpr int kMaxConstraints = 80;
inline constexpr int kMaxRows = kMaxVariables + kMaxConstraints;  // bounds first, then A's rows

inline constexpr double kInf = std::numeric_limits<double>::infinity();

using MatrixH = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                              kMaxVariables, kMaxVariables>;
using MatrixA = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                              kMaxConstraints, kMaxVariables>;
using VectorN = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxVariables, 1>;
using VectorM = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxConstraints, 1>;

/// One QP. Sizes are those of the members: n = H.rows(), m = A.rows(). Resizing within the
/// capacities never allocates (Eigen's inline storage), so the controller may assign expressions
/// (`p.H = Z.transpose() * Ap * Z`) every cycle.
struct Problem {
  MatrixH H;
  VectorN g;
  VectorN lb, ub;
  MatrixA A;
  VectorM lbA, ubA;

  /// Sets the sizes and makes every bound infinite, H, g and A zero. Never allocates.
  /// @pre 0 ≤ n ≤ kMaxVariables, 0 ≤ m ≤ kMaxConstraints (otherwise sizes are clamped).
  void Resize(int n, int m) noexcept;
  /// Sets the sizes and makes every bound infinite, but leaves H, g and A as they are: for a
  /// caller that writes every entry of them next (nothing zeroed that is overwritten). Never
  /// allocates. Same preconditions as Resize.
  void SetSizes(int n, int m) noexcept;
  int n() const noexcept { return static_cast<int>(H.rows()); }
  int m() const noexcept { return static_cast<int>(A.rows()); }
};

enum class [[nodiscard]] Status : std::uint8_t {
  kOptimal,         ///< KKT conditions of the given (unregularised) problem hold to tolerance
  kInfeasible,      ///< no x satisfies the constraints; Solution::y_* hold a Farkas certificate
  kUnbounded,       ///< the objective is unbounded below along Solution::direction
  kIterationLimit,  ///< Budget::max_iterations reached; Solution holds the best iterate
  kDeadline,        ///< Budget::deadline passed; Solution holds the best iterate
  kBadInput,        ///< NaN/Inf in H, g or A, NaN bound, wrong sizes, lb > ub, +inf lower bound,
                    ///< or data so large that x or the objective overflow
};

/// "optimal", "infeasible", ... (static strings, for tools and logs outside the cycle).
const char* ToString(Status status) noexcept;

/// Which side of a bound or constraint is active at the solution.
enum class Active : std::int8_t { kLower = -1, kInactive = 0, kUpper = 1, kEquality = 2 };

/// What a solve may use.
struct Budget {
  int max_iterations = 1000;  ///< active-set changes plus proximal (outer) iterations
  /// After this (on its clock: wall or the thread's CPU time) the solve stops with
  /// Status::kDeadline.
  std::optional<Deadline> deadline;
  /// Start from Solution's active set and multipliers (and, for a singular H, its x) as left by
  /// the previous solve of a problem with the same n and m. Ignored on a size mismatch. When H
  /// and A are bit-for-bit those of this Solver's previous solve, the solver instead continues
  /// from its own factorisation and working set (no refactorisation; docs/qp.md).
  bool warm_start = false;
};

/// Tolerances; the defaults suit problems scaled to O(1) data and are what the tests use.
struct Settings {
  double kkt_tolerance = 1e-10;        ///< relative, on every residual of KktResiduals
  double primal_tolerance = 1e-11;     ///< a row is violated above (1 + |bound|) * this
  double dependence_tolerance = 1e-13; ///< relative pivot below which an entering row is dependent
  /// Proximal weight for a singular H, relative to max H_ii (absolute for an LP, H = 0).
  double proximal_weight = 1e-7;
  /// H is known to be singular: start with the proximal weight at once instead of first trying
  /// ε = 0 (a factorisation that is bound to fail, often only at its last test).
  bool singular_hessian = false;
  int max_outer_iterations = 400;
};

/// Residuals of the KKT conditions of the unregularised problem, each relative (divided by
/// max(1, size of the terms it compares)) and in the max-norm:
///   stationarity   ‖H x + g + y_bounds + Aᵀ y_constraints‖ / max(1, ‖Hx‖, ‖g‖, ‖y_b‖, ‖Aᵀy_c‖)
///   primal         largest bound or constraint violation / max(1, ‖x‖, ‖Ax‖)
///   dual           largest multiplier on a side whose bound is infinite / max(1, ‖y‖)
///   complementarity largest |y_i| · distance of row i to the bound of its sign
///                  / max(1, ‖y‖ · max(1, ‖x‖, ‖Ax‖))
struct KktResiduals {
  double stationarity = 0.0;
  double primal = 0.0;
  double dual = 0.0;
  double complementarity = 0.0;
  double max() const noexcept;
};

/// What a solve used and found. Sized by Solve(); keep one per problem for warm starts.
struct Solution {
  VectorN x;              ///< the answer (or best iterate, see Status)
  VectorN y_bounds;       ///< multipliers of lb ≤ x ≤ ub (convention at the top of this file)
  VectorM y_constraints;  ///< multipliers of lbA ≤ Ax ≤ ubA
  std::array<Active, kMaxVariables> active_bounds{};          ///< first n entries used
  std::array<Active, kMaxConstraints> active_constraints{};   ///< first m entries used
  /// Status::kUnbounded: a direction d (‖d‖∞ = 1) with H d ≈ 0, gᵀd < 0, x + t d feasible ∀t ≥ 0.
  VectorN direction;
  double objective = 0.0;  ///< ½ xᵀHx + gᵀx at x
  Status status = Status::kBadInput;
  int iterations = 0;        ///< active-set changes plus outer iterations
  int outer_iterations = 0;  ///< proximal-point iterations (1 when H is positive definite)
  double solve_time_s = 0.0;
  double regularisation = 0.0;  ///< the proximal weight used last (0: H was factorised as is)
  KktResiduals kkt;
};

/// KKT residuals (above) of x, y for problem p. Allocates nothing.
KktResiduals ComputeKktResiduals(const Problem& p, const VectorN& x, const VectorN& y_bounds,
                                 const VectorM& y_constraints) noexcept;

}  // namespace hyq::qp
