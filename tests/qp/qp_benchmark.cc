// Solve times for the servo's QP sizes (docs/qp.md has the command and the numbers):
//   (a) random strictly convex, 20 variables, 28 inequalities (cond(H) = 1e2), cold and warm;
//   (b) Stage-I-shaped: rank-6 Hessian, 20 impulses z ≥ 0, friction and non-penetration rows.
// "Warm" solves the next cycle's problem (g and the bounds moved by 1 %) starting from the
// previous solution, as the servo does; the pair alternates so every solve is a warm one.
// Counters: max_iter is the worst iteration count seen, fail counts non-optimal answers.
#include <algorithm>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "qp/solver.h"
#include "tests/qp/qp_test_problems.h"

namespace hyq::qp {
namespace {

constexpr int kPoolSize = 64;

std::vector<Problem> MakePool(bool id_shaped, std::vector<Problem>* next) {
  std::mt19937_64 rng(id_shaped ? 2024 : 2023);
  std::vector<Problem> pool;
  for (int i = 0; i < kPoolSize; ++i) {
    pool.push_back(id_shaped ? testing::MakeIdShaped(4, &rng)
                             : testing::MakeRandomStrictlyConvex(20, 28, 1e2, &rng));
    next->push_back(pool.back());
    testing::Perturb(0.01, !id_shaped, &rng, &next->back());
  }
  return pool;
}

void Report(benchmark::State& state, int max_iter, int failures) {
  state.counters["max_iter"] = max_iter;
  state.counters["fail"] = failures;
}

void Cold(benchmark::State& state, bool id_shaped) {
  std::vector<Problem> next;
  const std::vector<Problem> pool = MakePool(id_shaped, &next);
  Solver solver;
  Solution s;
  int i = 0, max_iter = 0, failures = 0;
  for (auto _ : state) {
    const Status st = solver.Solve(pool[i], Budget{}, &s);
    benchmark::DoNotOptimize(s.x.data());
    failures += st != Status::kOptimal;
    max_iter = std::max(max_iter, s.iterations);
    i = (i + 1) % kPoolSize;
  }
  Report(state, max_iter, failures);
}

void Warm(benchmark::State& state, bool id_shaped) {
  std::vector<Problem> next;
  const std::vector<Problem> pool = MakePool(id_shaped, &next);
  Solver solver;
  std::vector<Solution> sol(kPoolSize);
  for (int i = 0; i < kPoolSize; ++i) (void)solver.Solve(pool[i], Budget{}, &sol[i]);
  Budget warm;
  warm.warm_start = true;
  int i = 0, flip = 1, max_iter = 0, failures = 0;
  for (auto _ : state) {
    const Problem& p = flip ? next[i] : pool[i];
    const Status st = solver.Solve(p, warm, &sol[i]);
    benchmark::DoNotOptimize(sol[i].x.data());
    failures += st != Status::kOptimal;
    max_iter = std::max(max_iter, sol[i].iterations);
    if (++i == kPoolSize) i = 0, flip ^= 1;
  }
  Report(state, max_iter, failures);
}

void BM_Random20x28_Cold(benchmark::State& state) { Cold(state, false); }
void BM_Random20x28_Warm(benchmark::State& state) { Warm(state, false); }
void BM_IdShaped4Feet_Cold(benchmark::State& state) { Cold(state, true); }
void BM_IdShaped4Feet_Warm(benchmark::State& state) { Warm(state, true); }

BENCHMARK(BM_Random20x28_Cold);
BENCHMARK(BM_Random20x28_Warm);
BENCHMARK(BM_IdShaped4Feet_Cold);
BENCHMARK(BM_IdShaped4Feet_Warm);

}  // namespace
}  // namespace hyq::qp

BENCHMARK_MAIN();
