// Per-cycle dynamics cost. Run: build/release/tests/dynamics/dynamics_benchmark
//   --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <cstdlib>
#include <memory>
#include <random>

#include <benchmark/benchmark.h>

#include "dynamics/cycle_dynamics.h"
#include "tests/dynamics/hyq_fixture.h"
#include "tests/support/latency_stats.h"

namespace hyq::dynamics {
namespace {

struct Fixture {
  Fixture() : d(std::make_unique<CycleDynamics>()) {
    std::mt19937_64 rng(1);
    for (auto& s : states) s = testing::MakeRandomState(testing::HyqModel(), &rng);
    if (ComputeCycleDynamics(testing::HyqModel(), states[0].q, states[0].v, d.get()) !=
        DynamicsStatus::kOk)
      std::abort();
  }
  std::array<testing::RandomState, 64> states;
  std::unique_ptr<CycleDynamics> d;
};

void BM_ForwardKinematics(benchmark::State& state) {
  Fixture f;
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = f.states[i++ % f.states.size()];
    ForwardKinematics(testing::HyqModel(), s.q, s.v, &f.d->kin);
    benchmark::DoNotOptimize(f.d->kin);
  }
}
BENCHMARK(BM_ForwardKinematics);

void BM_FootKinematics(benchmark::State& state) {
  Fixture f;
  for (auto _ : state) {
    ComputeFootKinematics(testing::HyqModel(), f.d->kin, &f.d->feet);
    benchmark::DoNotOptimize(f.d->feet);
  }
}
BENCHMARK(BM_FootKinematics);

void BM_Crba(benchmark::State& state) {
  Fixture f;
  for (auto _ : state) {
    Crba(testing::HyqModel(), f.d->kin, &f.d->crba_ws, &f.d->M);
    benchmark::DoNotOptimize(f.d->M);
  }
}
BENCHMARK(BM_Crba);

void BM_BiasForces(benchmark::State& state) {
  Fixture f;
  for (auto _ : state) {
    BiasForces(testing::HyqModel(), f.d->kin, &f.d->rnea_ws, &f.d->bias);
    benchmark::DoNotOptimize(f.d->bias);
  }
}
BENCHMARK(BM_BiasForces);

void BM_FactorMassMatrix(benchmark::State& state) {
  Fixture f;
  for (auto _ : state) {
    const auto s = FactorMassMatrix(f.d->M, &f.d->factor);
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_FactorMassMatrix);

void BM_InverseBlocks(benchmark::State& state) {
  Fixture f;
  for (auto _ : state) {
    ComputeInverseBlocks(f.d->M, f.d->factor, &f.d->inv);
    benchmark::DoNotOptimize(f.d->inv);
  }
}
BENCHMARK(BM_InverseBlocks);

void BM_MinvBlocksOnDemand(benchmark::State& state) {
  Fixture f;
  MinvBlocks blocks;
  for (auto _ : state) {
    ComputeMinvBlocks(f.d->factor, &blocks);
    benchmark::DoNotOptimize(blocks);
  }
}
BENCHMARK(BM_MinvBlocksOnDemand);

// "full dynamics per cycle": FK, M, bias, four foot Jacobians (+ J̇v), factorisation, and the
// M⁻¹ blocks the contact ID uses (A⁻¹, A⁻¹B, F⁻¹)
void BM_FullDynamicsPerCycle(benchmark::State& state) {
  Fixture f;
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = f.states[i++ % f.states.size()];
    const auto st = ComputeCycleDynamics(testing::HyqModel(), s.q, s.v, f.d.get());
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(f.d->inv);
  }
}
BENCHMARK(BM_FullDynamicsPerCycle);

// the same, each call timed on its own: p50 / p99 / p99.9 / max counters
void BM_FullDynamicsPerCycleTail(benchmark::State& state) {
  Fixture f;
  testing::LatencyRecorder rec(1'000'000);
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& s = f.states[i++ % f.states.size()];
    rec.Time([&] {
      const auto st = ComputeCycleDynamics(testing::HyqModel(), s.q, s.v, f.d.get());
      benchmark::DoNotOptimize(st);
    });
  }
  rec.Publish(&state);
}
BENCHMARK(BM_FullDynamicsPerCycleTail)->Iterations(200'000);

}  // namespace
}  // namespace hyq::dynamics

BENCHMARK_MAIN();
