// Whole inverse dynamics per cycle: dynamics + Stage I + Stage II (and the baselines), for 2, 3
// and 4 stance feet, warm-started cycle to cycle along a recorded trot (3 s of closed-loop
// trotting on μ = 0.1 in the MuJoCo HyQ). Per-call percentiles come from the latency counters.
//
//   build/release/tests/servo/id_benchmark --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "servo/control/controller.h"
#include "tests/servo/id_fixture.h"
#include "tools/experiment/experiment.h"
#include "tests/support/latency_stats.h"

namespace hyq::servo {
namespace {

std::array<bool, 4> Stance(int feet) {
  if (feet == 2) return {true, false, false, true};
  if (feet == 3) return {true, true, true, false};
  return {true, true, true, true};
}

// The ID problems of 3 s of closed-loop trotting on μ = 0.1 (MuJoCo HyQ, two-stage ID), recorded
// once; the cycles with `feet` feet in stance (3: the double-support cycles with rh lifted).
const std::vector<IdInput>& RecordedTrot(int feet) {
  static const std::vector<IdInput> all = [] {
    experiment::ExperimentConfig cfg;
    cfg.reference = Reference::Kind::kTrot;
    cfg.duration_s = 3.0;
    cfg.mu = 0.1;
    cfg.controller = experiment::StandardController(ControllerKind::kTwoStageId);
    cfg.record_id_inputs = true;
    return experiment::RunExperiment(testing::HyqModel(), cfg).id_inputs;
  }();
  static std::array<std::vector<IdInput>, 5> by_feet;
  if (by_feet[feet].empty()) {
    for (const IdInput& in : all) {
      const int n = in.stance[0] + in.stance[1] + in.stance[2] + in.stance[3];
      if (feet == 2 && n == 2) by_feet[2].push_back(in);
      if (feet >= 3 && n == 4) {
        IdInput c = in;
        c.stance = Stance(feet);
        by_feet[feet].push_back(c);
      }
    }
  }
  return by_feet[feet];
}

void BM_WholeId(benchmark::State& state) {
  const int feet = static_cast<int>(state.range(0));
  const auto kind = static_cast<ControllerKind>(state.range(1));
  const auto& seq = RecordedTrot(feet);
  ControllerConfig cfg;
  cfg.kind = kind;
  Controller ctl(testing::HyqModel(), cfg);
  auto dyn = std::make_unique<dynamics::CycleDynamics>();
  JointReference ref;
  ref.stance = Stance(feet);
  ContactEnvironment env;
  env.mu = {0.1, 0.1, 0.1, 0.1};
  IdOutput out;
  testing::LatencyRecorder rec(2'000'000);
  std::size_t i = 0;
  std::int64_t fallbacks = 0, iters1 = 0, iters2 = 0, max_iters = 0;
  for (auto _ : state) {
    const IdInput& in = seq[i++ % seq.size()];
    ref.qdd = in.qdd_des;
    ref.q = in.q.tail<12>();
    ref.qd = in.v.tail<12>();
    IdStatus st;
    rec.Time([&] {
      (void)dynamics::ComputeCycleDynamics(testing::HyqModel(), in.q, in.v, dyn.get());
      st = ctl.Compute(*dyn, in.q, in.v, ref, env, in.dt, &out);
    });
    if (st != IdStatus::kOk) ++fallbacks;
    iters1 += out.stage1.iterations;
    iters2 += out.stage2.iterations;
    max_iters = std::max<std::int64_t>(max_iters, out.stage1.iterations + out.stage2.iterations);
  }
  rec.Publish(&state);
  const double n = static_cast<double>(state.iterations());
  state.counters["fallbacks"] = static_cast<double>(fallbacks);
  state.counters["stage1_iters"] = static_cast<double>(iters1) / n;
  state.counters["stage2_iters"] = static_cast<double>(iters2) / n;
  state.counters["max_iters"] = static_cast<double>(max_iters);
  state.SetLabel(std::string(ToString(kind)) + ", " + std::to_string(feet) + " feet");
}

constexpr auto kTwo = static_cast<int>(ControllerKind::kTwoStageId);
constexpr auto kOne = static_cast<int>(ControllerKind::kStage1Id);
constexpr auto kNoSlip = static_cast<int>(ControllerKind::kNoSlipId);
BENCHMARK(BM_WholeId)
    ->Args({2, kTwo})->Args({3, kTwo})->Args({4, kTwo})
    ->Args({4, kOne})->Args({4, kNoSlip})
    ->Iterations(20000);

}  // namespace
}  // namespace hyq::servo

BENCHMARK_MAIN();
