// qp/ on feasible problems built to be as degenerate as Stage II of the contact inverse dynamics:
// a known feasible point x0 with many rows active at zero slack, duplicated, scaled, opposite
// and nonnegatively combined rows (implicit equalities, "pointed cone" closures as in
// P w ≥ −z with z = 0), rows of tiny norm, equalities, rank-deficient projection-like A and a
// positive semi-definite H. Every problem is feasible by construction (x0 meets every row
// exactly: x0 = 0 with right-hand sides ≤ 0, or dyadic data for which A x0 is exact in any
// summation order) and bounded below (g ∈ range(H), or a box), so the only right answer is
// kOptimal. Regression test for feasible problems declared infeasible by a "certificate" with a
// closed Cᵀw but no negative gap (qp/dual_active_set.cc, CertificateProvesInfeasibility).
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "qp/solver.h"
#include "tests/qp/qp_test_problems.h"

namespace hyq::qp {
namespace {

struct Degenerate {
  Problem p;
  VectorN x0;  // feasible exactly
  std::string what;
};

class Builder {
 public:
  Builder(std::mt19937_64* rng, int n, bool dyadic) : rng_(*rng), n_(n), dyadic_(dyadic) {}

  double U(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
  int I(int a, int b) { return std::uniform_int_distribution<int>(a, b)(rng_); }
  bool Coin(double p) { return U(0.0, 1.0) < p; }
  // dyadic numbers k / 1024 with |k| ≤ 2048: products with x0's k / 8 and sums of up to 40 of
  // them are exact in double, whatever the order
  double Entry() {
    if (!dyadic_) return std::normal_distribution<double>(0.0, 0.5)(rng_);
    return I(-2048, 2048) / 1024.0;
  }

  Eigen::VectorXd RandomRow() {
    Eigen::VectorXd a(n_);
    for (int j = 0; j < n_; ++j) a(j) = Entry();
    return a;
  }
  // a right-hand side for a ≥ side at x0: zero slack most of the time
  double Slack() {
    const double r = U(0.0, 1.0);
    if (r < 0.55 || dyadic_) return r < 0.7 ? 0.0 : I(1, 64) / 64.0;
    if (r < 0.75) return std::pow(10.0, U(-14.0, -11.0));  // "exactly 0" computed elsewhere
    return U(0.01, 0.5);
  }
  void Add(const Eigen::VectorXd& a, double lo, double hi) {
    rows.push_back(a);
    lo_.push_back(lo);
    hi_.push_back(hi);
  }

  std::mt19937_64& rng_;
  int n_;
  bool dyadic_;
  std::vector<Eigen::VectorXd> rows;
  std::vector<double> lo_, hi_;
};

Degenerate MakeDegenerate(std::mt19937_64* rng, int index) {
  std::uniform_int_distribution<int> pick_n(3, 20);
  const int n = pick_n(*rng);
  const bool dyadic = index % 4 == 3;
  Builder b(rng, n, dyadic);
  Degenerate out;
  out.x0.setZero(n);
  if (dyadic)
    for (int j = 0; j < n; ++j) out.x0(j) = b.I(-16, 16) / 8.0;
  const Eigen::VectorXd x0 = out.x0;
  auto value = [&](const Eigen::VectorXd& a) { return a.dot(x0); };  // exact by construction

  // base rows: random, or a projection-like block P = I − Q Qᵀ (rank n − k, its n rows
  // dependent), as the null-space rows of Stage II
  std::vector<int> zero_slack;
  const int base = b.I(n / 2, n + 2);
  if (!dyadic && b.Coin(0.5)) {
    const int k = b.I(1, std::max(1, n / 3));
    Eigen::MatrixXd Q = Eigen::MatrixXd::NullaryExpr(n, k, [&] { return b.Entry(); });
    Q = Eigen::HouseholderQR<Eigen::MatrixXd>(Q).householderQ() * Eigen::MatrixXd::Identity(n, k);
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) - Q * Q.transpose();
    for (int i = 0; i < std::min(n, base); ++i) {
      const double s = b.Slack();
      if (s == 0.0) zero_slack.push_back(static_cast<int>(b.rows.size()));
      b.Add(P.row(i).transpose(), -s, kInf);
    }
  }
  while (static_cast<int>(b.rows.size()) < base) {
    const Eigen::VectorXd a = b.RandomRow();
    const double s = b.Slack();
    if (s == 0.0) zero_slack.push_back(static_cast<int>(b.rows.size()));
    if (b.Coin(0.8)) b.Add(a, value(a) - s, kInf);
    else b.Add(-a, -kInf, value(-a) + s);  // the same kind of row, upper side
  }
  const int nbase = static_cast<int>(b.rows.size());
  // dependent rows, up to 2.5 n in all (capacity 80)
  const int target = std::min(kMaxConstraints, nbase + b.I(n / 2, 3 * n / 2 + 2));
  while (static_cast<int>(b.rows.size()) < target) {
    const int kind = b.I(0, 6);
    const int i = b.I(0, nbase - 1);
    const Eigen::VectorXd a = b.rows[i];
    const double lo = b.lo_[i], hi = b.hi_[i];
    if (kind == 0) {  // duplicate
      b.Add(a, lo, hi);
    } else if (kind == 1 && !dyadic) {  // scaled duplicate (the same side)
      const double s = b.U(0.1, 10.0);
      b.Add(s * a, lo * s, hi * s);
    } else if (kind == 2 && !zero_slack.empty()) {  // opposite side of a zero-slack row
      const int z = zero_slack[b.I(0, static_cast<int>(zero_slack.size()) - 1)];
      const Eigen::VectorXd az = b.rows[z];
      const double at = std::isfinite(b.lo_[z]) ? b.lo_[z] : b.hi_[z];
      if (b.Coin(0.5)) b.Add(-az, -kInf, -at);
      else b.Add(az, at, at);  // or an explicit equality on top of the inequality
    } else if (kind == 3 && zero_slack.size() >= 2) {
      // pointed-cone closure: −Σ c_i s_i a_i ≥ 0 over zero-slack rows (s_i their side) forces
      // every one of them to be active at zero slack (the Stage II "noeq" instances)
      const int count = b.I(2, std::min<int>(5, static_cast<int>(zero_slack.size())));
      Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
      for (int t = 0; t < count; ++t) {
        const int z = zero_slack[b.I(0, static_cast<int>(zero_slack.size()) - 1)];
        const double side = std::isfinite(b.lo_[z]) ? 1.0 : -1.0;
        const double w = dyadic ? b.I(1, 4) / 4.0 : b.U(0.2, 1.0);
        c += w * side * b.rows[z];
      }
      // −c·x0 is exact (x0 = 0, or dyadic data)
      b.Add(-c, value(-c), kInf);
    } else if (kind == 4 && zero_slack.size() >= 2) {  // implied nonnegative combination
      Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
      const int count = b.I(2, std::min<int>(4, static_cast<int>(zero_slack.size())));
      for (int t = 0; t < count; ++t) {
        const int z = zero_slack[b.I(0, static_cast<int>(zero_slack.size()) - 1)];
        const double side = std::isfinite(b.lo_[z]) ? 1.0 : -1.0;
        c += (dyadic ? b.I(1, 4) / 4.0 : b.U(0.2, 2.0)) * side * b.rows[z];
      }
      b.Add(c, value(c), kInf);
    } else if (kind == 5 && !dyadic) {  // a row of tiny norm (rounding of a zero row), at zero
      const Eigen::VectorXd t = std::pow(10.0, b.U(-7.0, -4.0)) * b.RandomRow();
      if (b.Coin(0.5)) b.Add(t, 0.0, 0.0);
      else b.Add(t, 0.0, kInf);
    } else {  // a fresh row through x0 (an equality now and then)
      const Eigen::VectorXd f = b.RandomRow();
      if (b.Coin(0.3)) b.Add(f, value(f), value(f));
      else b.Add(f, value(f), kInf);
    }
  }

  const int m = static_cast<int>(b.rows.size());
  Problem& p = out.p;
  p.Resize(n, m);
  for (int k = 0; k < m; ++k) {
    p.A.row(k) = b.rows[k].transpose();
    p.lbA(k) = b.lo_[k];
    p.ubA(k) = b.hi_[k];
  }
  // bounds: some active at x0 (lower or upper), some a box, the rest free
  const bool box = b.Coin(0.3);
  for (int j = 0; j < n; ++j) {
    if (box) {
      p.lb(j) = x0(j) - b.I(1, 8) / 4.0;
      p.ub(j) = x0(j) + b.I(1, 8) / 4.0;
    }
    const double r = b.U(0.0, 1.0);
    if (r < 0.25) p.lb(j) = x0(j);
    else if (r < 0.35) p.ub(j) = x0(j);
  }
  // H = ZᵀZ of rank 1 … n; g = Zᵀc (bounded below on any feasible set) or, with a box, any g
  const int rank = b.Coin(0.5) ? std::min(n, 6) : b.I(1, n);
  const Eigen::MatrixXd Z = Eigen::MatrixXd::NullaryExpr(rank, n, [&] { return b.U(-1.0, 1.0); });
  const Eigen::MatrixXd H = Z.transpose() * Z;
  p.H = 0.5 * (H + H.transpose());
  const Eigen::VectorXd c = Eigen::VectorXd::NullaryExpr(rank, [&] { return b.U(-1.0, 1.0); });
  p.g = Z.transpose() * c;
  if (box && b.Coin(0.5))
    for (int j = 0; j < n; ++j) p.g(j) += b.U(-1.0, 1.0);
  out.what = "degenerate #" + std::to_string(index) + " n " + std::to_string(n) + " m " +
             std::to_string(m) + " rank " + std::to_string(rank) + (dyadic ? " dyadic" : "") +
             (box ? " box" : "");
  return out;
}

// the largest violation of x0, relative as in KktResiduals::primal (0 by construction)
double Violation(const Problem& p, const VectorN& x) {
  double v = 0.0;
  const Eigen::VectorXd ax = p.A * x;
  for (int j = 0; j < p.n(); ++j) v = std::max({v, p.lb(j) - x(j), x(j) - p.ub(j)});
  for (int k = 0; k < p.m(); ++k) v = std::max({v, p.lbA(k) - ax(k), ax(k) - p.ubA(k)});
  return v;
}

// The bug this guards against: 2,492 of these 4,000 cold solves returned kInfeasible before
// the gap check. kInfeasible is never acceptable. A cold or warm solve may still stop at the
// iteration limit (9 of the 8,000 solves here, with 1e-7-norm rows, scaled duplicates and
// pointed-cone closures all at one vertex; none on the captured contact-ID instances): that is
// counted, must stay rare, and is reported (docs/qp.md, known limits).
// Σ|y_i|·|C_i x − b_i| (b_i the bound on y_i's side) + ‖stationarity residual‖₁ ‖x0 − x‖∞
double ObjectiveSlack(const Problem& p, const Solution& s, const VectorN& x0) {
  const Eigen::VectorXd ax = p.A * s.x;
  double slack = 0.0;
  for (int j = 0; j < p.n(); ++j) {
    const double y = s.y_bounds(j);
    if (y != 0.0) slack += std::fabs(y) * std::fabs(s.x(j) - (y > 0 ? p.ub(j) : p.lb(j)));
  }
  for (int k = 0; k < p.m(); ++k) {
    const double y = s.y_constraints(k);
    if (y != 0.0) slack += std::fabs(y) * std::fabs(ax(k) - (y > 0 ? p.ubA(k) : p.lbA(k)));
  }
  const Eigen::VectorXd r =
      p.H * s.x + p.g + s.y_bounds + p.A.transpose() * s.y_constraints;
  return slack + r.lpNorm<1>() * (x0 - s.x).lpNorm<Eigen::Infinity>();
}

TEST(QpDegenerateStress, FeasibleDegenerateProblemsAreNeverInfeasible) {
  std::mt19937_64 rng(20261123);
  Solver solver;
  constexpr int kProblems = 4000;
  int infeasible = 0, not_optimal = 0, warm_infeasible = 0, warm_not_optimal = 0;
  int worst_iterations = 0;
  double worst_kkt = 0.0;
  for (int t = 0; t < kProblems; ++t) {
    Degenerate d = MakeDegenerate(&rng, t);
    ASSERT_LE(Violation(d.p, d.x0), 0.0) << d.what << ": the construction is not feasible";
    Solution s;
    const Status st = solver.Solve(d.p, Budget{}, &s);
    infeasible += st == Status::kInfeasible;
    EXPECT_NE(st, Status::kInfeasible) << d.what;
    if (st != Status::kOptimal) {
      ++not_optimal;
      EXPECT_EQ(st, Status::kIterationLimit) << d.what << ": " << ToString(st);
      continue;
    }
    worst_iterations = std::max(worst_iterations, s.iterations);
    worst_kkt = std::max(worst_kkt, s.kkt.max());
    EXPECT_LE(ComputeKktResiduals(d.p, s.x, s.y_bounds, s.y_constraints).max(), 1e-9) << d.what;
    // the objective can be no worse than at the known feasible point, up to what the KKT
    // residuals allow (by convexity, f(x0) ≥ f(x) + ∇f(x)ᵀ(x0 − x), which gives
    // f(x) ≤ f(x0) + Σ|y_i|·|C_i x − b_i| + ‖Hx + g + y_b + Aᵀy_c‖₁ ‖x0 − x‖∞)
    const double f0 = 0.5 * d.x0.dot(d.p.H * d.x0) + d.p.g.dot(d.x0);
    EXPECT_LE(s.objective, f0 + ObjectiveSlack(d.p, s, d.x0) + 1e-12 * std::max(1.0, std::fabs(f0)))
        << d.what;
    // a servo-like warm re-solve: some lower sides move down a little (x0 stays feasible)
    Problem q = d.p;
    for (int k = 0; k < q.m(); ++k)
      if (std::isfinite(q.lbA(k)) && q.lbA(k) != q.ubA(k) && rng() % 2 == 0)
        q.lbA(k) -= 0.01 * std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    ASSERT_LE(Violation(q, d.x0), 0.0) << d.what;
    Budget warm;
    warm.warm_start = true;
    const Status st2 = solver.Solve(q, warm, &s);
    warm_infeasible += st2 == Status::kInfeasible;
    EXPECT_NE(st2, Status::kInfeasible) << d.what << " (warm)";
    if (st2 == Status::kOptimal) {
      EXPECT_LE(ComputeKktResiduals(q, s.x, s.y_bounds, s.y_constraints).max(), 1e-9)
          << d.what << " (warm)";
    } else {
      ++warm_not_optimal;
      EXPECT_EQ(st2, Status::kIterationLimit) << d.what << " (warm): " << ToString(st2);
    }
  }
  EXPECT_EQ(infeasible + warm_infeasible, 0);
  EXPECT_LE(not_optimal + warm_not_optimal, kProblems / 100);  // 9 of the 8,000 solves now
  RecordProperty("iteration_limit_cold", not_optimal);
  RecordProperty("iteration_limit_warm", warm_not_optimal);
  std::printf("%d degenerate feasible problems: cold %d infeasible, %d iteration limit; warm %d "
              "infeasible, %d iteration limit; worst %d iterations, worst kkt %.1e\n",
              kProblems, infeasible, not_optimal, warm_infeasible, warm_not_optimal,
              worst_iterations, worst_kkt);
}

// The other side: the same degenerate problems made infeasible by a margin δ ∈ [1e-4, 1], with
// one more row −Σ c_i a_i x ≥ δ over zero-slack rows a_i x ≥ 0 (x0 = 0 problems). Never kOptimal;
// kInfeasible with a verified Farkas certificate for most. Measured (docs/qp.md, known limits):
// 953 of 1,000 certified, 945 of them verified by IsFarkasCertificate (5 have a valid but weak
// gap of ~-5e-10 < its 1e-9 margin, 3 a 1e-12 residual on a free variable), 47 stop at the
// iteration limit (λ grows huge on the way to the certificate and u is lost in cancellation).
// Before the gap check: 991 "certified", but 125 of those certificates proved nothing.
TEST(QpDegenerateStress, InfeasibleDegenerateProblemsAreCertified) {
  std::mt19937_64 rng(20261124);
  Solver solver;
  int made = 0, certified = 0, verified = 0, limit = 0;
  for (int t = 0; made < 1000 && t < 4000; ++t) {
    Degenerate d = MakeDegenerate(&rng, t);
    Problem& p = d.p;
    if (t % 4 == 3 || p.m() >= kMaxConstraints) continue;  // dyadic ones have x0 ≠ 0
    // zero-slack lower-sided rows of A (b = 0) and their sum with positive weights
    Eigen::VectorXd c = Eigen::VectorXd::Zero(p.n());
    int used = 0;
    for (int k = 0; k < p.m(); ++k) {
      if (p.lbA(k) == 0.0 && p.ubA(k) == kInf && rng() % 2 == 0) {
        c += std::uniform_real_distribution<double>(0.2, 1.0)(rng) * p.A.row(k).transpose();
        ++used;
      }
    }
    if (used < 2 || c.norm() < 1e-3) continue;
    ++made;
    const int m = p.m();
    Problem q;
    q.Resize(p.n(), m + 1);
    q.H = p.H;
    q.g = p.g;
    q.lb = p.lb;
    q.ub = p.ub;
    q.A.topRows(m) = p.A;
    q.lbA.head(m) = p.lbA;
    q.ubA.head(m) = p.ubA;
    q.A.row(m) = -c.transpose();
    q.lbA(m) = std::pow(10.0, std::uniform_real_distribution<double>(-4.0, 0.0)(rng));
    Solution s;
    const Status st = solver.Solve(q, Budget{}, &s);
    EXPECT_NE(st, Status::kOptimal) << d.what << " + infeasible row, kkt " << s.kkt.max();
    if (st == Status::kInfeasible) {
      ++certified;
      verified += static_cast<bool>(testing::IsFarkasCertificate(q, s));
    } else {
      ++limit;
      EXPECT_EQ(st, Status::kIterationLimit) << d.what << ": " << ToString(st);
    }
  }
  EXPECT_GE(made, 500);
  EXPECT_GE(certified, made * 9 / 10);
  EXPECT_GE(verified, certified * 98 / 100);
  RecordProperty("certified", certified);
  RecordProperty("verified", verified);
  RecordProperty("iteration_limit", limit);
  std::printf("%d infeasible degenerate problems: %d certified (%d verified), %d iteration "
              "limit\n",
              made, certified, verified, limit);
}

}  // namespace
}  // namespace hyq::qp
