// Solve times for the servo's QP sizes (docs/qp.md has the command and the numbers):
//   (a) Random20x28: random strictly convex, 20 variables, 28 inequalities A x ≤ b, cond(H) 1e2;
//   (b) IdShaped4Feet: Stage-I-shaped, rank-6 Hessian, 20 impulses z ≥ 0, 4 friction and
//       4 non-penetration rows.
// Each runs on 8 base problems, each followed through 32 "servo cycles" in which g and b (for
// (b): the non-penetration bounds) take a 1 % random-walk step:
//   _Cold            every cycle solved from scratch;
//   _Warm            warm start from the previous cycle's solution, same H and A (the solver
//                    keeps its factorisation and working set);
//   _WarmNewMatrices warm start, but H (and so the factorisation) changes every cycle, as in the
//                    servo where H and A come from the dynamics of the moment.
// Counters: max_iter is the worst iteration count seen (active-set changes plus outer
// iterations), max_outer the worst proximal-iteration count, fail counts non-optimal answers.
#include <algorithm>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "qp/solver.h"
#include "tests/qp/qp_test_problems.h"

namespace hyq::qp {
namespace {

constexpr int kBases = 8;
constexpr int kCycles = 32;

struct Sequence {
  Problem problem;       // the base problem, rewritten every cycle
  MatrixH H[2];          // the base H and a perturbed one (for _WarmNewMatrices)
  std::vector<VectorN> g;
  std::vector<VectorM> lbA, ubA;
};

std::vector<Sequence> MakeSequences(bool id_shaped) {
  std::mt19937_64 rng(id_shaped ? 2024 : 2023);
  std::normal_distribution<double> N(0.0, 1e-3);
  std::vector<Sequence> out(kBases);
  for (Sequence& s : out) {
    s.problem = id_shaped ? testing::MakeIdShaped(4, &rng)
                          : testing::MakeRandomStrictlyConvex(20, 28, 1e2, &rng);
    s.H[0] = s.problem.H;
    MatrixH E = MatrixH::Zero(s.problem.n(), s.problem.n());
    for (int i = 0; i < E.rows(); ++i)
      for (int j = 0; j <= i; ++j) E(i, j) = E(j, i) = N(rng) * s.H[0].cwiseAbs().maxCoeff();
    // keep the perturbed H semi-definite: H + E Eᵀ-like term
    s.H[1] = s.H[0] + E * E.transpose();
    Problem p = s.problem;
    for (int t = 0; t < kCycles; ++t) {
      testing::Perturb(0.01, !id_shaped, &rng, &p);
      s.g.push_back(p.g);
      s.lbA.push_back(p.lbA);
      s.ubA.push_back(p.ubA);
    }
  }
  return out;
}

enum class Mode { kCold, kWarm, kWarmNewMatrices };

void Run(benchmark::State& state, bool id_shaped, Mode mode) {
  std::vector<Sequence> seq = MakeSequences(id_shaped);
  Solver solver;
  std::vector<Solution> sol(kBases);
  for (int b = 0; b < kBases; ++b) (void)solver.Solve(seq[b].problem, Budget{}, &sol[b]);
  Budget budget;
  budget.warm_start = mode != Mode::kCold;
  int b = 0, t = 0, max_iter = 0, max_outer = 0, failures = 0;
  for (auto _ : state) {
    Sequence& s = seq[b];
    s.problem.g = s.g[t];
    s.problem.lbA = s.lbA[t];
    s.problem.ubA = s.ubA[t];
    if (mode == Mode::kWarmNewMatrices) s.problem.H = s.H[t & 1];
    const Status st = solver.Solve(s.problem, budget, &sol[b]);
    benchmark::DoNotOptimize(sol[b].x.data());
    failures += st != Status::kOptimal;
    max_iter = std::max(max_iter, sol[b].iterations);
    max_outer = std::max(max_outer, sol[b].outer_iterations);
    if (++t == kCycles) {
      t = 0;
      b = (b + 1) % kBases;
    }
  }
  state.counters["max_iter"] = max_iter;
  state.counters["max_outer"] = max_outer;
  state.counters["fail"] = failures;
}

void BM_Random20x28_Cold(benchmark::State& state) { Run(state, false, Mode::kCold); }
void BM_Random20x28_Warm(benchmark::State& state) { Run(state, false, Mode::kWarm); }
void BM_Random20x28_WarmNewMatrices(benchmark::State& state) {
  Run(state, false, Mode::kWarmNewMatrices);
}
void BM_IdShaped4Feet_Cold(benchmark::State& state) { Run(state, true, Mode::kCold); }
void BM_IdShaped4Feet_Warm(benchmark::State& state) { Run(state, true, Mode::kWarm); }
void BM_IdShaped4Feet_WarmNewMatrices(benchmark::State& state) {
  Run(state, true, Mode::kWarmNewMatrices);
}

BENCHMARK(BM_Random20x28_Cold);
BENCHMARK(BM_Random20x28_Warm);
BENCHMARK(BM_Random20x28_WarmNewMatrices);
BENCHMARK(BM_IdShaped4Feet_Cold);
BENCHMARK(BM_IdShaped4Feet_Warm);
BENCHMARK(BM_IdShaped4Feet_WarmNewMatrices);

}  // namespace
}  // namespace hyq::qp

BENCHMARK_MAIN();
