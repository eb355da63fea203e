// Whole inverse dynamics per cycle: dynamics + Stage I + Stage II (and the baselines), for 2, 3
// and 4 stance feet, warm-started cycle to cycle along a recorded trot (3 s of closed-loop
// trotting on μ = 0.1 in the MuJoCo HyQ). Per-call percentiles come from the latency counters;
// input_p50_ns and input_p999_ns are the same percentiles over the cycles of each cycle's fastest
// call, the tail that the inputs cause (iterations) without the machine's interruptions.
//
//   build/release/tests/servo/id_benchmark --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
//
// BM_IdQp times the solver alone on the very QPs the two-stage ID forms in BM_WholeId's loop
// (recorded once, one pass of the controller over the trot): warm (Stage I then Stage II per
// cycle, each warm-started from the previous cycle's answer of the same sizes, new H and A every
// cycle) and cold (each stage from scratch). `--write-qp-instances=FILE` writes those instances
// (and the states they came from) for timing other solvers on them (docs/benchmarks.md has the
// format) and exits.
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
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

// The controller replaying recorded inputs with `feet` in stance: one cycle is the dynamics and
// the controller's answer, what BM_WholeId times.
struct Replay {
  Replay(int feet, ControllerKind kind) : ctl(testing::HyqModel(), Config(kind)) {
    ref.stance = Stance(feet);
    env.mu = {0.1, 0.1, 0.1, 0.1};
  }
  static ControllerConfig Config(ControllerKind kind) {
    ControllerConfig cfg;
    cfg.kind = kind;
    return cfg;
  }
  IdStatus Cycle(const IdInput& in, IdOutput* out) {
    ref.qdd = in.qdd_des;
    ref.q = in.q.tail<12>();
    ref.qd = in.v.tail<12>();
    (void)dynamics::ComputeCycleDynamics(testing::HyqModel(), in.q, in.v, dyn.get());
    return ctl.Compute(*dyn, in.q, in.v, ref, env, in.dt, out);
  }
  Controller ctl;
  std::unique_ptr<dynamics::CycleDynamics> dyn = std::make_unique<dynamics::CycleDynamics>();
  JointReference ref;
  ContactEnvironment env;
};

void BM_WholeId(benchmark::State& state) {
  const int feet = static_cast<int>(state.range(0));
  const auto kind = static_cast<ControllerKind>(state.range(1));
  const auto& seq = RecordedTrot(feet);
  Replay replay(feet, kind);
  IdOutput out;
  testing::LatencyRecorder rec(2'000'000);
  std::size_t i = 0;
  std::int64_t fallbacks = 0, iters1 = 0, iters2 = 0, max_iters = 0;
  // each cycle's fastest call over the passes after the first (the sequence repeats in order, so
  // from the second pass on every cycle is warm-started from the same previous one)
  std::vector<double> fastest(seq.size(), std::numeric_limits<double>::infinity());
  for (auto _ : state) {
    const std::size_t k = i++ % seq.size();
    const IdInput& in = seq[k];
    IdStatus st;
    const double ns = rec.Time([&] { st = replay.Cycle(in, &out); });
    if (i > seq.size()) fastest[k] = std::min(fastest[k], ns);  // the first pass starts cold
    if (st != IdStatus::kOk) ++fallbacks;
    iters1 += out.stage1.iterations;
    iters2 += out.stage2.iterations;
    max_iters = std::max<std::int64_t>(max_iters, out.stage1.iterations + out.stage2.iterations);
  }
  rec.Publish(&state);
  if (static_cast<std::size_t>(state.iterations()) >= 2 * seq.size()) {
    std::erase(fastest, std::numeric_limits<double>::infinity());
    testing::LatencyRecorder::PublishPerInput(std::move(fastest), &state);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["fallbacks"] = static_cast<double>(fallbacks);
  state.counters["stage1_iters"] = static_cast<double>(iters1) / n;
  state.counters["stage2_iters"] = static_cast<double>(iters2) / n;
  state.counters["max_iters"] = static_cast<double>(max_iters);
  state.SetLabel(std::string(ToString(kind)) + ", " + std::to_string(feet) + " feet");
}

// One stage's QP of one cycle, stored at its own size (a qp::Problem has inline storage for the
// largest one).
struct QpInstance {
  int n = 0, m = 0;
  std::vector<double> H, g, lb, ub, A, lbA, ubA;  // column-major matrices
  double objective = 0.0;                        // the controller's answer
  qp::Status status = qp::Status::kBadInput;

  static QpInstance From(const qp::Problem& p, double objective, qp::Status status) {
    QpInstance q;
    q.n = p.n();
    q.m = p.m();
    q.H.assign(p.H.data(), p.H.data() + q.n * q.n);
    q.g.assign(p.g.data(), p.g.data() + q.n);
    q.lb.assign(p.lb.data(), p.lb.data() + q.n);
    q.ub.assign(p.ub.data(), p.ub.data() + q.n);
    q.A.assign(p.A.data(), p.A.data() + q.m * q.n);
    q.lbA.assign(p.lbA.data(), p.lbA.data() + q.m);
    q.ubA.assign(p.ubA.data(), p.ubA.data() + q.m);
    q.objective = objective;
    q.status = status;
    return q;
  }
  void To(qp::Problem* p) const {
    p->H = Eigen::Map<const qp::MatrixH>(H.data(), n, n);
    p->g = Eigen::Map<const qp::VectorN>(g.data(), n);
    p->lb = Eigen::Map<const qp::VectorN>(lb.data(), n);
    p->ub = Eigen::Map<const qp::VectorN>(ub.data(), n);
    p->A = Eigen::Map<const qp::MatrixA>(A.data(), m, n);
    p->lbA = Eigen::Map<const qp::VectorM>(lbA.data(), m);
    p->ubA = Eigen::Map<const qp::VectorM>(ubA.data(), m);
  }
};

struct IdCycle {
  const IdInput* input = nullptr;
  QpInstance stage1;
  bool has_stage2 = false;
  QpInstance stage2;
};

// One pass of the two-stage ID over the recorded trot, keeping each cycle's QPs.
const std::vector<IdCycle>& IdInstances(int feet) {
  static std::array<std::vector<IdCycle>, 5> by_feet;
  std::vector<IdCycle>& out = by_feet[feet];
  if (!out.empty()) return out;
  const auto& seq = RecordedTrot(feet);
  Replay replay(feet, ControllerKind::kTwoStageId);
  IdOutput o;
  for (const IdInput& in : seq) {
    (void)replay.Cycle(in, &o);
    if (!o.stage1.ran) continue;
    IdCycle c;
    c.input = &in;
    const TwoStageId& id = replay.ctl.two_stage();
    c.stage1 = QpInstance::From(id.stage1_problem(), o.stage1.objective, o.stage1.status);
    c.has_stage2 = o.stage2.ran;
    // the stage report's objective is ½‖τ‖², not the QP's: recompute the QP's at its answer
    if (c.has_stage2) c.stage2 = QpInstance::From(id.stage2_problem(), 0.0, o.stage2.status);
    out.push_back(std::move(c));
  }
  // the QPs' own objectives, from the solver the ID uses, cold (what any solver must match)
  qp::Solver solver(IdQpSettings());
  qp::Solution s;
  qp::Problem p;
  for (IdCycle& c : out) {
    for (QpInstance* q : {&c.stage1, &c.stage2}) {
      if (q == &c.stage2 && !c.has_stage2) continue;
      q->To(&p);
      q->status = solver.Solve(p, qp::Budget{}, &s);
      q->objective = s.objective;
    }
  }
  return out;
}

enum class QpMode { kWarm, kColdStage1, kColdStage2 };

// BM_IdQp/feet/mode: kWarm times Stage I + Stage II of each cycle (warm from the previous
// cycle's answers of the same sizes), the cold modes one stage each from scratch.
void BM_IdQp(benchmark::State& state) {
  const int feet = static_cast<int>(state.range(0));
  const auto mode = static_cast<QpMode>(state.range(1));
  const auto& cycles = IdInstances(feet);
  qp::Solver solver1(IdQpSettings()), solver2(IdQpSettings());
  qp::Solution s1, s2;
  qp::Problem p1, p2;
  testing::LatencyRecorder rec(2'000'000);
  std::size_t i = 0;
  std::int64_t failures = 0, worst_objective_ppb = 0, iterations = 0, outer = 0;
  for (auto _ : state) {
    const IdCycle& c = cycles[i++ % cycles.size()];
    const bool two = c.has_stage2 && mode != QpMode::kColdStage1;
    const bool one = mode != QpMode::kColdStage2;
    if (!one && !two) continue;
    c.stage1.To(&p1);
    if (two) c.stage2.To(&p2);
    qp::Budget b1, b2;
    b1.warm_start = mode == QpMode::kWarm && s1.x.size() == p1.n() && s1.y_constraints.size() == p1.m();
    b2.warm_start = mode == QpMode::kWarm && s2.x.size() == p2.n() && s2.y_constraints.size() == p2.m();
    qp::Status st1 = qp::Status::kOptimal, st2 = qp::Status::kOptimal;
    rec.Time([&] {
      if (one) st1 = solver1.Solve(p1, b1, &s1);
      if (two) st2 = solver2.Solve(p2, b2, &s2);
    });
    failures += (st1 != qp::Status::kOptimal) + (st2 != qp::Status::kOptimal);
    auto tally = [&](const qp::Solution& s, const QpInstance& q) {
      const double rel = std::abs(s.objective - q.objective) / std::max(1.0, std::abs(q.objective));
      worst_objective_ppb = std::max<std::int64_t>(worst_objective_ppb, std::llround(rel * 1e9));
      iterations += s.iterations;
      outer += s.outer_iterations;
    };
    if (one) tally(s1, c.stage1);
    if (two) tally(s2, c.stage2);
  }
  rec.Publish(&state);
  state.counters["fail"] = static_cast<double>(failures);
  state.counters["objective_ppb"] = static_cast<double>(worst_objective_ppb);
  state.counters["iters"] = static_cast<double>(iterations) / static_cast<double>(state.iterations());
  state.counters["outer"] = static_cast<double>(outer) / static_cast<double>(state.iterations());
  state.SetLabel(std::to_string(feet) + " feet, " +
                 (mode == QpMode::kWarm ? "warm I+II" : mode == QpMode::kColdStage1 ? "cold I" : "cold II"));
}

// The instances file (little-endian): "HYQIDQP1", int32 records; per record int32 feet,
// int32 cycle, double q[19], double v[18], int32 stages, then per stage int32 stage, int32 n,
// int32 m, H (n × n), g, lb, ub (n), A (m × n, column-major), lbA, ubA (m), double objective,
// int32 status (0: optimal).
int WriteQpInstances(const char* path) {
  std::FILE* f = std::fopen(path, "wb");
  if (!f) {
    std::fprintf(stderr, "id_benchmark: cannot write the instances file %s: %s\n", path,
                 std::strerror(errno));
    return 1;
  }
  auto i32 = [&](int v) { std::fwrite(&v, sizeof v, 1, f); };
  auto f64 = [&](const double* d, std::size_t k) { std::fwrite(d, sizeof(double), k, f); };
  auto problem = [&](int stage, const QpInstance& q) {
    i32(stage);
    i32(q.n);
    i32(q.m);
    for (const auto* v : {&q.H, &q.g, &q.lb, &q.ub, &q.A, &q.lbA, &q.ubA}) f64(v->data(), v->size());
    f64(&q.objective, 1);
    i32(static_cast<int>(q.status));
  };
  std::fwrite("HYQIDQP1", 1, 8, f);
  int records = 0;
  for (int feet = 2; feet <= 4; ++feet) records += static_cast<int>(IdInstances(feet).size());
  i32(records);
  for (int feet = 2; feet <= 4; ++feet) {
    int cycle = 0;
    for (const IdCycle& c : IdInstances(feet)) {
      i32(feet);
      i32(cycle++);
      f64(c.input->q.data(), 19);
      f64(c.input->v.data(), 18);
      i32(c.has_stage2 ? 2 : 1);
      problem(1, c.stage1);
      if (c.has_stage2) problem(2, c.stage2);
    }
  }
  const bool ok = std::fclose(f) == 0;
  std::fprintf(ok ? stdout : stderr, "id_benchmark: %s %d cycles to %s\n",
               ok ? "wrote" : "failed writing", records, path);
  return ok ? 0 : 1;
}

constexpr auto kTwo = static_cast<int>(ControllerKind::kTwoStageId);
constexpr auto kOne = static_cast<int>(ControllerKind::kStage1Id);
constexpr auto kNoSlip = static_cast<int>(ControllerKind::kNoSlipId);
BENCHMARK(BM_WholeId)
    ->Args({2, kTwo})->Args({3, kTwo})->Args({4, kTwo})
    ->Args({4, kOne})->Args({4, kNoSlip})
    ->Iterations(20000);
BENCHMARK(BM_IdQp)
    ->ArgsProduct({{2, 3, 4}, {static_cast<int>(QpMode::kWarm), static_cast<int>(QpMode::kColdStage1),
                               static_cast<int>(QpMode::kColdStage2)}})
    ->Iterations(20000);

}  // namespace
}  // namespace hyq::servo

int main(int argc, char** argv) {
  constexpr const char* kWrite = "--write-qp-instances=";
  for (int i = 1; i < argc; ++i)
    if (std::strncmp(argv[i], kWrite, std::strlen(kWrite)) == 0)
      return hyq::servo::WriteQpInstances(argv[i] + std::strlen(kWrite));
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
