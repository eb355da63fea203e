// Whole inverse dynamics per cycle: dynamics + Stage I + Stage II (and the baselines), for 2, 3
// and 4 stance feet, warm-started cycle to cycle along a body-sway motion with the stance feet
// fixed (contact-consistent). Per-call percentiles come from the latency counters.
//
//   build/release/tests/servo/id_benchmark --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "servo/controller.h"
#include "tests/servo/id_fixture.h"
#include "tests/support/latency_stats.h"

namespace hyq::servo {
namespace {

constexpr int kCycles = 2000;  // 2 s of motion at 1 kHz

std::array<bool, 4> Stance(int feet) {
  if (feet == 2) return {true, false, false, true};
  if (feet == 3) return {true, true, false, true};
  return {true, true, true, true};
}

// A 2 s sway: lateral 1 Hz, vertical 2 Hz, roll 0.5 Hz, all stance feet fixed.
std::vector<IdInput> Sway(int feet) {
  std::vector<IdInput> seq;
  std::mt19937_64 rng(7);
  const IdInput base = testing::StandingInput(&rng, Stance(4), 0.0);
  for (int k = 0; k < kCycles; ++k) {
    const double t = k * 1e-3, w = 2 * M_PI;
    IdInput in = base;
    in.q(1) += 0.03 * std::sin(w * t);
    in.q(2) += 0.02 * std::sin(2 * w * t);
    dynamics::Vector6d vb = dynamics::Vector6d::Zero(), ab = dynamics::Vector6d::Zero();
    vb(1) = 0.03 * w * std::cos(w * t);
    vb(2) = 0.04 * w * std::cos(2 * w * t);
    ab(1) = -0.03 * w * w * std::sin(w * t);
    ab(2) = -0.08 * w * w * std::sin(2 * w * t);
    testing::MakeContactConsistent(&in, vb, ab, &rng);
    in.stance = Stance(feet);
    in.mu = {0.6, 0.6, 0.6, 0.6};
    seq.push_back(in);
  }
  return seq;
}

void BM_WholeId(benchmark::State& state) {
  const int feet = static_cast<int>(state.range(0));
  const auto kind = static_cast<ControllerKind>(state.range(1));
  const auto seq = Sway(feet);
  ControllerConfig cfg;
  cfg.kind = kind;
  Controller ctl(testing::HyqModel(), cfg);
  auto dyn = std::make_unique<dynamics::CycleDynamics>();
  JointReference ref;
  ref.stance = Stance(feet);
  ContactEnvironment env;
  env.mu = {0.6, 0.6, 0.6, 0.6};
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
