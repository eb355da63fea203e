// qp/: planted solutions, KKT certificates, degenerate and infeasible problems, warm starts,
// statuses and the no-allocation proof (docs/qp.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "qp/solver.h"
#include "qp/workspace.h"
#include "tests/qp/qp_test_problems.h"
#include "tests/support/no_heap_guard.h"

namespace hyq::qp {
namespace {

using testing::MakePlanted;
using testing::Planted;
using testing::PlantedOptions;

constexpr double kKktLimit = 1e-9;

void ExpectFarkas(const Problem& p, const Solution& s) {
  EXPECT_TRUE(testing::IsFarkasCertificate(p, s));
}

void ExpectKkt(const Problem& p, const Solution& s, const std::string& what) {
  const KktResiduals r = ComputeKktResiduals(p, s.x, s.y_bounds, s.y_constraints);
  EXPECT_LE(r.stationarity, kKktLimit) << what;
  EXPECT_LE(r.primal, kKktLimit) << what;
  EXPECT_LE(r.dual, kKktLimit) << what;
  EXPECT_LE(r.complementarity, kKktLimit) << what;
  EXPECT_LE(s.kkt.max(), kKktLimit) << what;
}

void ExpectPlanted(const Planted& t, const Solution& s, double tol, const std::string& what) {
  const int n = t.problem.n(), m = t.problem.m();
  ASSERT_EQ(s.status, Status::kOptimal) << what << " kkt " << s.kkt.max();
  ExpectKkt(t.problem, s, what);
  EXPECT_LE((s.x - t.x).cwiseAbs().maxCoeff(), tol) << what;
  EXPECT_LE((s.y_bounds - t.y_bounds).cwiseAbs().maxCoeff(), tol * 10) << what;
  if (m > 0) {
    EXPECT_LE((s.y_constraints - t.y_constraints).cwiseAbs().maxCoeff(), tol * 10) << what;
  }
  for (int i = 0; i < n; ++i) EXPECT_EQ(s.active_bounds[i], t.active_bounds[i]) << what << " b" << i;
  for (int k = 0; k < m; ++k)
    EXPECT_EQ(s.active_constraints[k], t.active_constraints[k]) << what << " c" << k;
}

// Solves t's problem with the default budget and checks the planted solution; returns it.
Solution SolvePlanted(Solver& solver, const Planted& t, double tol, const std::string& what) {
  Solution s;
  (void)solver.Solve(t.problem, Budget{}, &s);
  ExpectPlanted(t, s, tol, what);
  return s;
}

struct PlantedCase {
  PlantedOptions o;
  double x_tol;
  // x is only as accurate as (KKT residual) × (condition of the reduced problem): the
  // ill-conditioned singular case asks for tighter KKT residuals to pin x down
  double kkt_tolerance = Settings{}.kkt_tolerance;
};

TEST(QpPlanted, WellConditionedToIllConditioned) {
  std::mt19937_64 rng(1);
  Solver solver;
  const PlantedCase cases[] = {
      {{.n = 5, .m = 4, .condition = 1, .active_bounds = 1, .active_constraints = 2}, 1e-12},
      {{.n = 10, .m = 10, .condition = 1e2, .active_bounds = 2, .active_constraints = 3}, 1e-11},
      {{.n = 20, .m = 28, .condition = 1e4, .active_bounds = 3, .active_constraints = 8}, 1e-9},
      {{.n = 20, .m = 28, .condition = 1e8, .active_bounds = 3, .active_constraints = 8}, 1e-5},
      {{.n = 40, .m = 80, .condition = 1e6, .active_bounds = 8, .active_constraints = 20}, 1e-7},
      {{.n = 40, .m = 80, .condition = 1e8, .active_bounds = 10, .active_constraints = 25}, 1e-5},
      {{.n = 20, .m = 20, .condition = 1e3, .active_bounds = 2, .active_constraints = 8,
        .equalities = 4}, 1e-10},
  };
  for (const PlantedCase& c : cases) {
    for (int rep = 0; rep < 20; ++rep) {
      const Planted t = MakePlanted(c.o, &rng);
      SolvePlanted(solver, t, c.x_tol,
                   "n=" + std::to_string(c.o.n) + " cond=" + std::to_string(c.o.condition) +
                       " rep=" + std::to_string(rep));
    }
  }
}

TEST(QpPlanted, RankDeficientHessian) {
  std::mt19937_64 rng(2);
  const PlantedCase cases[] = {
      // n − rank ≤ number of active rows, so x* is unique
      {{.n = 10, .m = 10, .condition = 1e2, .rank = 6, .active_bounds = 2, .active_constraints = 3}, 1e-7},
      {{.n = 20, .m = 28, .condition = 1e3, .rank = 6, .active_bounds = 6, .active_constraints = 10}, 1e-7},
      {{.n = 20, .m = 28, .condition = 1e8, .rank = 10, .active_bounds = 4, .active_constraints = 8}, 1e-4, 1e-14},
      {{.n = 30, .m = 40, .condition = 1e4, .rank = 15, .active_bounds = 5, .active_constraints = 12}, 1e-6, 1e-14},
  };
  for (const PlantedCase& c : cases) {
    Settings settings;
    settings.kkt_tolerance = c.kkt_tolerance;
    Solver solver(settings);
    for (int rep = 0; rep < 20; ++rep) {
      const Planted t = MakePlanted(c.o, &rng);
      const Solution s = SolvePlanted(solver, t, c.x_tol,
                                      "rank=" + std::to_string(c.o.rank) + " n=" +
                                          std::to_string(c.o.n) + " rep=" + std::to_string(rep));
      EXPECT_GT(s.regularisation, 0.0);
    }
  }
}

TEST(QpPlanted, LinearProgramAtAVertex) {
  std::mt19937_64 rng(3);
  Solver solver;
  for (int rep = 0; rep < 30; ++rep) {
    PlantedOptions o{.n = 12, .m = 16, .rank = 0, .active_bounds = 5, .active_constraints = 7};
    const Planted t = MakePlanted(o, &rng);
    ASSERT_EQ(t.problem.H.cwiseAbs().maxCoeff(), 0.0);
    SolvePlanted(solver, t, 1e-9, "LP rep " + std::to_string(rep));
  }
}

TEST(QpDegenerate, NothingActive) {
  std::mt19937_64 rng(4);
  Solver solver;
  const Planted t = MakePlanted({.n = 15, .m = 20, .condition = 1e3, .active_bounds = 0,
                                 .active_constraints = 0}, &rng);
  const Solution s = SolvePlanted(solver, t, 1e-11, "nothing active");
  EXPECT_EQ(s.iterations, 1);  // one outer iteration, no active-set change
}

TEST(QpDegenerate, AllBoundsActive) {
  std::mt19937_64 rng(5);
  Solver solver;
  for (int rank : {20, 5, 0}) {
    const Planted t = MakePlanted({.n = 20, .m = 10, .condition = 1e2, .rank = rank,
                                   .active_bounds = 20, .active_constraints = 0}, &rng);
    SolvePlanted(solver, t, 1e-10, "all bounds, rank " + std::to_string(rank));
  }
}

TEST(QpDegenerate, DuplicateAndDependentActiveRows) {
  std::mt19937_64 rng(6);
  Settings settings;
  settings.kkt_tolerance = 1e-13;  // x is compared: tighter than the default (see QpPlanted)
  Solver solver(settings);
  for (int rep = 0; rep < 20; ++rep) {
    Planted t = MakePlanted({.n = 10, .m = 8, .condition = 1e2, .rank = rep % 2 ? 10 : 4,
                             .active_bounds = 3, .active_constraints = 4}, &rng);
    Problem& p = t.problem;
    // append: a copy of an active row, a copy of its bound pair, and a sum of two active rows
    // whose bound is the sum of theirs (consistent, dependent)
    Problem q;
    q.Resize(p.n(), p.m() + 3);
    q.H = p.H;
    q.g = p.g;
    q.lb = p.lb;
    q.ub = p.ub;
    q.A.topRows(p.m()) = p.A;
    q.lbA.head(p.m()) = p.lbA;
    q.ubA.head(p.m()) = p.ubA;
    int a1 = -1, a2 = -1;
    for (int k = 0; k < p.m(); ++k) {
      if (t.active_constraints[k] != Active::kUpper) continue;
      if (a1 < 0) {
        a1 = k;
      } else if (a2 < 0) {
        a2 = k;
      }
    }
    if (a1 < 0) continue;
    const int m = p.m();
    q.A.row(m) = p.A.row(a1);
    q.lbA(m) = p.lbA(a1);
    q.ubA(m) = p.ubA(a1);
    q.A.row(m + 1) = 2.0 * p.A.row(a1);  // scaled duplicate
    q.lbA(m + 1) = 2.0 * p.lbA(a1);
    q.ubA(m + 1) = 2.0 * p.ubA(a1);
    const int b = a2 >= 0 ? a2 : a1;
    q.A.row(m + 2) = p.A.row(a1) + p.A.row(b);
    q.lbA(m + 2) = -kInf;
    q.ubA(m + 2) = p.ubA(a1) + p.ubA(b);
    Solution s;
    (void)solver.Solve(q, Budget{}, &s);
    ASSERT_EQ(s.status, Status::kOptimal) << rep;
    ExpectKkt(q, s, "dependent rows rep " + std::to_string(rep));
    EXPECT_LE((s.x - t.x).cwiseAbs().maxCoeff(), 1e-8) << rep;
    // the multipliers are not unique, but the total force on x is: y_b + Aᵀ y_c
    const Eigen::VectorXd f_expected = t.y_bounds + p.A.transpose() * t.y_constraints;
    const Eigen::VectorXd f = s.y_bounds + q.A.transpose() * s.y_constraints;
    EXPECT_LE((f - f_expected).cwiseAbs().maxCoeff(), 1e-8) << rep;
  }
}

TEST(QpInfeasible, CertificateVerified) {
  std::mt19937_64 rng(7);
  Solver solver;
  // 1) bounds against a constraint: x ≥ 1 (bounds) and Σ x ≤ −1
  {
    Problem p;
    p.Resize(4, 1);
    p.H.setIdentity();
    p.lb.setOnes();
    p.A.setOnes();
    p.ubA(0) = -1.0;
    Solution s;
    EXPECT_EQ(solver.Solve(p, Budget{}, &s), Status::kInfeasible);
    ExpectFarkas(p, s);
  }
  // 2) random: rows of a feasible problem plus a row contradicting a positive combination
  for (int rep = 0; rep < 40; ++rep) {
    const int n = 8, m = 10;
    Planted t = MakePlanted({.n = n, .m = m, .condition = 1e2, .rank = rep % 3 == 0 ? 3 : n,
                             .active_bounds = 2, .active_constraints = 4}, &rng);
    Problem p;
    p.Resize(n, m + 1);
    p.H = t.problem.H;
    p.g = t.problem.g;
    p.lb = t.problem.lb;
    p.ub = t.problem.ub;
    p.A.topRows(m) = t.problem.A;
    p.lbA.head(m) = t.problem.lbA;
    p.ubA.head(m) = t.problem.ubA;
    // a_new = Σ_k c_k a_k over rows with a finite lower bound: a_newᵀx ≥ Σ c_k lbA_k always
    // holds, so demand a_newᵀx ≤ Σ c_k lbA_k − 1
    Eigen::VectorXd a = Eigen::VectorXd::Zero(n);
    double lower = 0.0;
    for (int k = 0; k < m; ++k)
      if (std::isfinite(p.lbA(k))) {
        const double c = std::uniform_real_distribution<double>(0.2, 1.0)(rng);
        a += c * p.A.row(k).transpose();
        lower += c * p.lbA(k);
      }
    p.A.row(m) = a.transpose();
    p.ubA(m) = lower - 1.0;
    Solution s;
    EXPECT_EQ(solver.Solve(p, Budget{}, &s), Status::kInfeasible) << rep;
    ExpectFarkas(p, s);
  }
  // 3) contradicting equalities in an LP
  {
    Problem p;
    p.Resize(3, 3);
    p.A << 1, 1, 0, 0, 1, 1, 1, 2, 1;
    p.lbA << 1, 1, 3;
    p.ubA << 1, 1, 3;  // row 3 = row 1 + row 2 demands 2 = 3
    p.g << 1, 1, 1;
    Solution s;
    EXPECT_EQ(solver.Solve(p, Budget{}, &s), Status::kInfeasible);
    ExpectFarkas(p, s);
  }
}

TEST(QpUnbounded, DirectionVerified) {
  Solver solver;
  // LP: min −x0 − x1 s.t. x ≥ 0, x0 − x1 ≤ 1
  Problem p;
  p.Resize(3, 1);
  p.g << -1, -1, 0;
  p.lb.setZero();
  p.ub(2) = 1.0;
  p.A << 1, -1, 0;
  p.ubA(0) = 1.0;
  Solution s;
  EXPECT_EQ(solver.Solve(p, Budget{}, &s), Status::kUnbounded);
  const Eigen::VectorXd d = s.direction;
  EXPECT_NEAR(d.cwiseAbs().maxCoeff(), 1.0, 1e-12);
  EXPECT_LT(p.g.dot(d), -1e-6);
  EXPECT_GE(d(0), -1e-9);
  EXPECT_GE(d(1), -1e-9);
  EXPECT_LE(std::fabs(d(2)), 1e-9);
  EXPECT_LE((p.A * d)(0), 1e-9);
  // semi-definite QP: H = diag(1, 0), g = (0, −1), x1 ≤ nothing
  Problem q;
  q.Resize(2, 0);
  q.H(0, 0) = 1.0;
  q.g << 0.5, -1.0;
  EXPECT_EQ(solver.Solve(q, Budget{}, &s), Status::kUnbounded);
  EXPECT_NEAR(s.direction(1), 1.0, 1e-9);
  EXPECT_NEAR(s.direction(0), 0.0, 1e-9);
}

TEST(QpWarmStart, SameAnswerAsColdStart) {
  std::mt19937_64 rng(8);
  Solver cold_solver, warm_solver;
  for (int rep = 0; rep < 30; ++rep) {
    const int rank = rep % 3 == 0 ? 12 : 20;
    Planted t = MakePlanted({.n = 20, .m = 28, .condition = 1e3, .rank = rank, .active_bounds = 4,
                             .active_constraints = 8}, &rng);
    Solution warm;
    ASSERT_EQ(warm_solver.Solve(t.problem, Budget{}, &warm), Status::kOptimal);
    // the next cycle: a nearby problem
    std::normal_distribution<double> N(0.0, 1e-2);
    for (int i = 0; i < t.problem.n(); ++i) t.problem.g(i) += N(rng);
    for (int k = 0; k < t.problem.m(); ++k) {
      const double shift = N(rng);
      t.problem.lbA(k) += shift;
      t.problem.ubA(k) += shift;
    }
    Solution cold;
    ASSERT_EQ(cold_solver.Solve(t.problem, Budget{}, &cold), Status::kOptimal);
    Budget budget;
    budget.warm_start = true;
    ASSERT_EQ(warm_solver.Solve(t.problem, budget, &warm), Status::kOptimal);
    ExpectKkt(t.problem, warm, "warm");
    EXPECT_LE((warm.x - cold.x).cwiseAbs().maxCoeff(), 1e-8) << rep;
    EXPECT_LE((warm.y_constraints - cold.y_constraints).cwiseAbs().maxCoeff(), 1e-7) << rep;
    EXPECT_LE(warm.iterations, cold.iterations) << rep;
  }
}

TEST(QpWarmStart, NewMatricesAndChangedRowsGiveTheColdAnswer) {
  std::mt19937_64 rng(13);
  Solver cold_solver, warm_solver;
  for (int rep = 0; rep < 30; ++rep) {
    Planted t = MakePlanted({.n = 15, .m = 20, .condition = 1e2, .rank = rep % 2 ? 15 : 9,
                             .active_bounds = 3, .active_constraints = 6, .equalities = 1}, &rng);
    Solution warm;
    ASSERT_EQ(warm_solver.Solve(t.problem, Budget{}, &warm), Status::kOptimal);
    Problem& p = t.problem;
    switch (rep % 3) {
      case 0: {  // H changes (a new factorisation, the working set rebuilt from *warm)
        Eigen::MatrixXd E = 1e-2 * Eigen::MatrixXd::Random(p.n(), p.n());
        p.H += E * E.transpose();
        break;
      }
      case 1:  // every active constraint loses the side it was active on
        for (int k = 0; k < p.m(); ++k) {
          if (warm.active_constraints[k] == Active::kUpper) p.ubA(k) = kInf;
          if (warm.active_constraints[k] == Active::kLower) p.lbA(k) = -kInf;
        }
        break;
      default:  // the equality becomes an inequality, an inactive row an equality
        for (int k = 0; k < p.m(); ++k) {
          if (warm.active_constraints[k] == Active::kEquality) p.ubA(k) += 0.5;
        }
        for (int k = 0; k < p.m(); ++k) {
          if (warm.active_constraints[k] == Active::kInactive && std::isfinite(p.lbA(k))) {
            p.ubA(k) = p.lbA(k);
            break;
          }
        }
    }
    Solution cold;
    const Status cold_status = cold_solver.Solve(p, Budget{}, &cold);
    Budget budget;
    budget.warm_start = true;
    const Status warm_status = warm_solver.Solve(p, budget, &warm);
    ASSERT_EQ(warm_status, cold_status) << rep;
    if (cold_status != Status::kOptimal) continue;
    ExpectKkt(p, warm, "warm after change " + std::to_string(rep));
    EXPECT_NEAR(warm.objective, cold.objective, 1e-9 * std::max(1.0, std::fabs(cold.objective)))
        << rep;
    if (rep % 2) {
      EXPECT_LE((warm.x - cold.x).cwiseAbs().maxCoeff(), 1e-7) << rep;
    }
  }
}

TEST(QpAllocation, NoHeapInColdOrWarmSolve) {
  HYQ_REQUIRE_HEAP_HOOKS();
  std::mt19937_64 rng(9);
  Solver solver;
  const Planted t = MakePlanted({.n = 20, .m = 28, .condition = 1e4, .active_bounds = 4,
                                 .active_constraints = 8}, &rng);
  const Planted singular = MakePlanted({.n = 20, .m = 28, .condition = 1e2, .rank = 6,
                                        .active_bounds = 6, .active_constraints = 10}, &rng);
  Problem infeasible;  // x ≥ 1 and Σ x ≤ −1
  infeasible.Resize(4, 1);
  infeasible.H.setIdentity();
  infeasible.lb.setOnes();
  infeasible.A.setOnes();
  infeasible.ubA(0) = -1.0;
  Problem unbounded;  // min −x, x ≥ 0
  unbounded.Resize(1, 0);
  unbounded.g(0) = -1.0;
  unbounded.lb(0) = 0.0;
  Solution s;
  Budget warm;
  warm.warm_start = true;
  warm.deadline = Deadline::In(std::chrono::hours(1));
  Budget tight;
  tight.max_iterations = 3;
  std::size_t allocations = 0;
  {
    hyq::testing::NoHeapGuard guard;
    (void)solver.Solve(t.problem, Budget{}, &s);    // cold
    (void)solver.Solve(t.problem, warm, &s);        // warm, with a deadline
    (void)solver.Solve(singular.problem, Budget{}, &s);  // proximal path
    (void)solver.Solve(singular.problem, warm, &s);
    (void)solver.Solve(infeasible, Budget{}, &s);
    (void)solver.Solve(unbounded, Budget{}, &s);
    (void)solver.Solve(t.problem, tight, &s);  // iteration limit
    Problem bad;  // no sizes: bad input, also without allocating
    (void)solver.Solve(bad, Budget{}, &s);
    allocations = guard.allocations();
  }
  EXPECT_EQ(allocations, 0u);
}

TEST(QpStatus, BadInput) {
  Solver solver;
  std::mt19937_64 rng(10);
  const Planted t = MakePlanted({.n = 6, .m = 4}, &rng);
  Solution s;
  auto expect_bad = [&](Problem p, const char* what) {
    EXPECT_EQ(solver.Solve(p, Budget{}, &s), Status::kBadInput) << what;
    EXPECT_EQ(s.status, Status::kBadInput) << what;
  };
  Problem p = t.problem;
  p.H(1, 2) = std::nan("");
  expect_bad(p, "NaN in H");
  // every place a non-finite entry of H can be, alone or mirrored (the input check finds them in
  // its symmetry pass)
  for (const double bad : {std::nan(""), kInf, -kInf}) {
    for (const auto& [i, j] :
         {std::pair{0, 3}, std::pair{3, 0}, std::pair{2, 2}, std::pair{5, 5}}) {
      p = t.problem;
      p.H(i, j) = bad;
      expect_bad(p, "one non-finite entry of H");
      p.H(j, i) = bad;
      expect_bad(p, "a mirrored pair of non-finite entries of H");
    }
  }
  p = t.problem;
  p.g(0) = kInf;
  expect_bad(p, "Inf in g");
  p = t.problem;
  p.A(3, 1) = -kInf;
  expect_bad(p, "Inf in A");
  p = t.problem;
  p.lb(2) = std::nan("");
  expect_bad(p, "NaN bound");
  p = t.problem;
  p.lb(2) = 2.0;
  p.ub(2) = 1.0;
  expect_bad(p, "lb > ub");
  p = t.problem;
  p.lbA(1) = 3.0;
  p.ubA(1) = -3.0;
  expect_bad(p, "lbA > ubA");
  p = t.problem;
  p.g.resize(5);
  expect_bad(p, "g size");
  p = t.problem;
  p.ubA.resize(3);
  expect_bad(p, "ubA size");
  p = t.problem;
  p.H(0, 1) += 1.0;
  expect_bad(p, "asymmetric H");
  p = t.problem;
  p.H(0, 0) = -1.0;
  expect_bad(p, "indefinite H");
  expect_bad(Problem{}, "empty");
  EXPECT_STREQ(ToString(Status::kBadInput), "bad_input");
}

// Finite data whose solve overflows: before, H = diag(1e308) and H = 1e-300, g = 1e100 came back
// kOptimal with x NaN or ±Inf (a NaN residual passed the KKT test, std::max drops it).
TEST(QpStatus, NeverOptimalWithANonFiniteAnswer) {
  Solver solver;
  Solution s;
  auto expect_finite_or_bad = [&](const Problem& p, const char* what) {
    const Status st = solver.Solve(p, Budget{}, &s);
    EXPECT_EQ(st, s.status) << what;
    if (st == Status::kOptimal || st == Status::kIterationLimit || st == Status::kDeadline) {
      EXPECT_TRUE(s.x.allFinite()) << what << ": " << ToString(st);
      EXPECT_TRUE(std::isfinite(s.objective)) << what << ": " << ToString(st);
    }
  };
  Problem p;
  p.Resize(2, 0);
  p.H.diagonal().setConstant(1e308);
  p.g.setConstant(1.0);
  expect_finite_or_bad(p, "H = diag(1e308)");
  p.lb.setConstant(-1.0);
  expect_finite_or_bad(p, "H = diag(1e308), lb = -1");
  p.Resize(2, 0);
  p.H.setIdentity();
  p.g << 1e308, -1e308;
  expect_finite_or_bad(p, "g = ±1e308");
  p.Resize(1, 0);
  p.H(0, 0) = 1e-300;
  p.g(0) = 1e100;
  expect_finite_or_bad(p, "x = -1e400");
  EXPECT_EQ(s.status, Status::kBadInput);
  p.Resize(2, 1);
  p.H.setIdentity();
  p.A << 1e308, 1e308;
  p.lbA(0) = 1.0;
  expect_finite_or_bad(p, "A x overflows");
  KktResiduals k;
  k.primal = std::nan("");
  EXPECT_TRUE(std::isnan(k.max()));  // a NaN residual is never "within tolerance"
}

// The full capacity, well conditioned, with 35 active rows: long enough to stop early.
Planted FullSizePlanted() {
  std::mt19937_64 rng(11);
  return MakePlanted({.n = 40, .m = 80, .condition = 1e2, .active_bounds = 10,
                      .active_constraints = 25}, &rng);
}

TEST(QpStatus, IterationLimitAndDeadlineReturnTheLastIterate) {
  Solver solver;
  const Planted t = FullSizePlanted();
  Solution s;
  Budget b;
  b.max_iterations = 5;
  EXPECT_EQ(solver.Solve(t.problem, b, &s), Status::kIterationLimit);
  EXPECT_EQ(s.x.size(), 40);
  EXPECT_TRUE(s.x.allFinite());
  EXPECT_GT(s.kkt.primal, 0.0);  // not yet feasible, and it says so
  b.max_iterations = 1000;
  b.deadline = Deadline::At(std::chrono::steady_clock::now());
  EXPECT_EQ(solver.Solve(t.problem, b, &s), Status::kDeadline);
  EXPECT_TRUE(s.x.allFinite());
  // the full solve from the deadline's partial state still ends at the planted optimum
  b.deadline.reset();
  b.warm_start = true;
  (void)solver.Solve(t.problem, b, &s);
  ExpectPlanted(t, s, 1e-10, "after deadline");
}

// Lock-step budgets (qp/deadline.h): time the thread is not running does not count on its CPU
// clock, and the wall-clock bound is only a bound.
TEST(QpDeadline, ThreadCpuTimeIgnoresTimeAsleepAndCountsWork) {
  using namespace std::chrono_literals;
  // 50 ms: this VM charges a descheduled vCPU to the running thread's CPU time, a few ms at a
  // time when the host is busy (with a 2 ms budget this test failed then)
  const Deadline wall = Deadline::In(50ms);
  const Deadline cpu = Deadline::In(50ms, DeadlineClock::kThreadCpu);
  std::this_thread::sleep_for(100ms);
  EXPECT_TRUE(wall.Passed());
  EXPECT_FALSE(cpu.Passed()) << "100 ms asleep used up a 50 ms CPU-time budget";
  EXPECT_GT(cpu.Remaining(), 25ms);
  // a solve under it, after the sleep, is not stopped by the wall time
  Solver solver;
  const Planted t = FullSizePlanted();
  Solution s;
  Budget b;
  b.deadline = cpu;
  EXPECT_EQ(solver.Solve(t.problem, b, &s), Status::kOptimal);
  b.deadline = wall;
  EXPECT_EQ(solver.Solve(t.problem, b, &s), Status::kDeadline);
  // work does count: spinning ends it
  const auto give_up = std::chrono::steady_clock::now() + 2s;
  volatile double sink = 0.0;
  while (!cpu.Passed() && std::chrono::steady_clock::now() < give_up) sink = sink + 1.0;
  EXPECT_TRUE(cpu.Passed());
  EXPECT_EQ(cpu.Remaining(), 0ns);
}

TEST(QpDeadline, ShareKeepsTheRestForLater) {
  using namespace std::chrono_literals;
  for (const DeadlineClock clock : {DeadlineClock::kMonotonic, DeadlineClock::kThreadCpu}) {
    SCOPED_TRACE(clock == DeadlineClock::kThreadCpu ? "thread CPU clock" : "wall clock");
    const Deadline d = Deadline::In(100ms, clock);
    const Deadline part = d.Share(0.25);
    // read back to back: the thread may have been preempted since In() (the VMs here stall for
    // 5-15 ms under load), which shortens both by the same wall time, not what Share() kept
    const auto left = d.Remaining(), part_left = part.Remaining();
    EXPECT_EQ(part.clock(), clock);
    EXPECT_LE(part_left, 25ms + 1ms);
    // kept: 75 % of what was left at Share(), which was at most 100 ms
    EXPECT_LE(left - part_left, 75ms + 1ms);
    EXPECT_GE(left - part_left, 60ms) << "Share(0.25) kept too little (or a >20 ms stall)";
    // Share(0) leaves nothing on the wall clock; on the CPU clock it leaves the attempt the time
    // the thread was preempted since In() (the wall-clock bound undercounts the CPU time left)
    if (clock == DeadlineClock::kMonotonic) {
      EXPECT_FALSE(d.Share(0.0).Remaining() > 1ms);
    }
  }
}

// A sweep over mixed random problems: planted (cond 1 … 1e6, rank-deficient, equalities, n up
// to 40, m up to 80), ID-shaped (1 to 4 feet) and random strictly convex ones; every cold solve
// must be optimal to the KKT tolerance and a warm re-solve must stay optimal.
// (On far larger sweeps about 2 in 10,000 rank-deficient problems with nearly parallel rows end
// in kIterationLimit; docs/qp.md, "Known limits".)
TEST(QpSweep, MixedRandomProblems) {
  std::mt19937_64 rng(777);
  std::uniform_int_distribution<int> U(0, 1000000);
  Solver solver;
  int worst = 0, solved = 0;
  for (int it = 0; it < 4000; ++it) {
    const int kind = it % 4;
    Problem p;
    if (kind <= 1) {
      const int n = 2 + U(rng) % 39, m = U(rng) % 81;
      const int rank = kind == 1 ? U(rng) % (n + 1) : n;
      int ab = U(rng) % (n + 1);
      const int ac = std::min(m, U(rng) % (n + 1));
      if (ab + ac > n) ab = n - ac;
      if (ab + ac < n - rank) ab = std::min(n - ac, n - rank - ac + ab);
      if (ab + ac < n - rank) continue;
      const double cond = std::pow(10.0, U(rng) % 7);
      p = MakePlanted({.n = n, .m = m, .condition = cond, .rank = rank, .active_bounds = ab,
                       .active_constraints = ac,
                       .equalities = ac > 0 ? (U(rng) % (ac + 1)) / 2 : 0}, &rng).problem;
    } else if (kind == 2) {
      p = testing::MakeIdShaped(1 + U(rng) % 4, &rng);
    } else {
      const int n = 2 + U(rng) % 39, m = U(rng) % 81;
      p = testing::MakeRandomStrictlyConvex(n, m, std::pow(10.0, U(rng) % 7), &rng);
    }
    Solution s;
    ASSERT_EQ(solver.Solve(p, Budget{}, &s), Status::kOptimal)
        << "problem " << it << " kind " << kind << " kkt " << s.kkt.max();
    ASSERT_LE(s.kkt.max(), kKktLimit) << it;
    worst = std::max(worst, s.iterations);
    Budget warm;
    warm.warm_start = true;
    ASSERT_EQ(solver.Solve(p, warm, &s), Status::kOptimal) << "warm, problem " << it;
    ++solved;
  }
  RecordProperty("worst_iterations", worst);
  EXPECT_GT(solved, 3500);
}

TEST(QpIdShaped, RankSixHessianOptimal) {
  std::mt19937_64 rng(12);
  Solver solver;
  int worst = 0;
  for (int rep = 0; rep < 100; ++rep) {
    const Problem p = testing::MakeIdShaped(4, &rng);
    Solution s;
    const Status st = solver.Solve(p, Budget{}, &s);
    ASSERT_EQ(st, Status::kOptimal) << rep << " kkt " << s.kkt.max();
    ExpectKkt(p, s, "ID " + std::to_string(rep));
    worst = std::max(worst, s.iterations);
  }
  RecordProperty("worst_iterations", worst);
}

// The solver's own KKT check sums the multipliers' terms over its working set only; for
// multipliers that are zero outside that set it must report what the full check reports. Sizes
// with and without a compiled instance (qp/workspace.h, WithSize), sides finite and infinite.
TEST(QpKkt, WorkingSetSumsMatchTheFullCheck) {
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int n : {5, 7, 10, 14}) {
    for (int rep = 0; rep < 50; ++rep) {
      const int m = 3 + rep % 9;
      Problem p;
      p.Resize(n, m);
      const Eigen::MatrixXd B = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return u(rng); });
      p.H = B * B.transpose();
      for (int i = 0; i < n; ++i) p.g(i) = u(rng);
      for (int k = 0; k < m; ++k)
        for (int j = 0; j < n; ++j) p.A(k, j) = u(rng);
      auto bounds = [&](double* lo, double* hi) {
        const int kind = static_cast<int>(rng() % 4);  // both, lower only, upper only, none
        *lo = kind == 0 || kind == 1 ? -1.0 + 0.5 * u(rng) : -kInf;
        *hi = kind == 0 || kind == 2 ? 1.0 + 0.5 * u(rng) : kInf;
      };
      for (int i = 0; i < n; ++i) bounds(&p.lb(i), &p.ub(i));
      for (int k = 0; k < m; ++k) bounds(&p.lbA(k), &p.ubA(k));
      VectorN x(n), yb = VectorN::Zero(n);
      VectorM yc = VectorM::Zero(m);
      for (int i = 0; i < n; ++i) x(i) = u(rng);
      std::vector<int> support;
      for (int r = 0; r < n + m; ++r) {
        if (rng() % 3 != 0) continue;
        support.push_back(r);
        (r < n ? yb(r) : yc(r - n)) = 2.0 * u(rng);
      }
      double hx_full[kMaxVariables], ax_full[kMaxConstraints], hx[kMaxVariables],
          ax[kMaxConstraints];
      const KktResiduals full =
          internal::KktResidualsAndProducts(p, x, yb, yc, hx_full, ax_full);
      const KktResiduals on_set = internal::KktResidualsAndProducts(
          p, x, yb, yc, hx, ax, support.data(), static_cast<int>(support.size()));
      const std::string what = "n " + std::to_string(n) + " rep " + std::to_string(rep);
      EXPECT_NEAR(on_set.stationarity, full.stationarity, 1e-14) << what;
      EXPECT_EQ(on_set.primal, full.primal) << what;
      EXPECT_EQ(on_set.dual, full.dual) << what;
      EXPECT_EQ(on_set.complementarity, full.complementarity) << what;
      for (int i = 0; i < n; ++i) EXPECT_EQ(hx[i], hx_full[i]) << what;
      for (int k = 0; k < m; ++k) EXPECT_EQ(ax[k], ax_full[k]) << what;
      // and the full check agrees with the public one
      const KktResiduals pub = ComputeKktResiduals(p, x, yb, yc);
      EXPECT_EQ(pub.max(), full.max()) << what;
    }
  }
}

}  // namespace
}  // namespace hyq::qp
