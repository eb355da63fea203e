// Test problems for qp/: planted solutions [after DAQP's generate_test_QP: choose the optimum,
// the active set and the multipliers, then build g and the bounds so that they are exact] and
// inverse-dynamics-shaped problems like Stage I of the two-stage ID (DESIGN.md §2).
#pragma once

#include <random>

#include <gtest/gtest.h>

#include "qp/problem.h"

namespace hyq::qp::testing {

struct PlantedOptions {
  int n = 10;
  int m = 10;
  double condition = 1e2;     // of H on its range: eigenvalues log-spaced in [1/condition, 1]
  int rank = -1;              // < n: H has n − rank zero eigenvalues
  int active_bounds = 2;      // how many bounds are active at x*
  int active_constraints = 3; // how many rows of A are active at x*
  int equalities = 0;         // of the active constraints, how many are equalities
  double infinite_fraction = 0.3;  // inactive sides left infinite
};

struct Planted {
  Problem problem;
  VectorN x;
  VectorN y_bounds;
  VectorM y_constraints;
  std::array<Active, kMaxVariables> active_bounds{};
  std::array<Active, kMaxConstraints> active_constraints{};
};

/// A problem whose unique optimum is x with multipliers y (strict complementarity, linearly
/// independent active rows; unique x also for a singular H when enough rows are active).
Planted MakePlanted(const PlantedOptions& options, std::mt19937_64* rng);

/// H = Qᵀ diag Q with log-spaced eigenvalues in [1/condition, 1] (zero beyond rank).
MatrixH RandomHessian(int n, double condition, int rank, std::mt19937_64* rng);

/// Stage-I-shaped problem (DESIGN.md §2): z = [c_N; c_D] for `feet` feet (5 unknowns each:
/// 1 normal, 4 tangent directions), H = ZᵀMZ with Z 6 × 5·feet (rank ≤ 6), z ≥ 0, one friction
/// row μ c_N − Σ c_D ≥ 0 per foot and 6 rows N v* ≥ 0 (non-penetration, v* = Z z + p).
Problem MakeIdShaped(int feet, std::mt19937_64* rng);

/// Random strictly convex problem: n variables, m one-sided inequalities A x ≤ b (A random,
/// feasible at a random point, about a third active at the optimum), H with the given condition
/// number.
Problem MakeRandomStrictlyConvex(int n, int m, double condition, std::mt19937_64* rng);

/// The next servo cycle's problem: the finite bounds of A's rows and (when move_g) g moved by
/// `relative` (Gaussian). Keep g for ID-shaped problems: g ∈ range(Zᵀ) is what bounds them.
void Perturb(double relative, bool move_g, std::mt19937_64* rng, Problem* p);

/// Whether s.y_bounds, s.y_constraints form a Farkas certificate for p: with w = (y_b, y_c),
/// ‖y_b + Aᵀ y_c‖ ≈ 0 (relative 1e-9), w_i > 0 only on finite upper sides, w_i < 0 only on finite
/// lower sides, and Σ_{w>0} w·upper + Σ_{w<0} w·lower < 0: then no x satisfies every row.
::testing::AssertionResult IsFarkasCertificate(const Problem& p, const Solution& s);

}  // namespace hyq::qp::testing
