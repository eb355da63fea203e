// Cost of one lock-step cycle of the simulated HyQ: the robot's part (emulator Poll answering
// the SYNC, actuator model, MuJoCo step, sensors) and the whole loop with the HAL master, over
// in-process loopback buses.
#include <benchmark/benchmark.h>

#include "tests/hil/hil_rig.h"

namespace hyq::testing {
namespace {

void BM_LockStepCycle(benchmark::State& state) {
  LoopbackRig rig;
  rig.BringUp();
  for (int i = 0; i < 50; ++i) (void)rig.Cycle([](hal::ProcessImage& im) { StandingPd(HilModel(), im); });
  double robot_ns = 0;
  for (auto _ : state) {
    (void)rig.hal->Read(rig.now());
    StandingPd(HilModel(), rig.hal->image());
    (void)rig.hal->Write(rig.now());
    const std::int64_t t0 = MonotonicNs();
    benchmark::DoNotOptimize(rig.robot->PollLockStep());
    robot_ns += static_cast<double>(MonotonicNs() - t0);
  }
  state.counters["robot_us"] = benchmark::Counter(robot_ns * 1e-3 / static_cast<double>(state.iterations()));
  state.counters["sim_speed_x"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 1e-3, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LockStepCycle)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hyq::testing

BENCHMARK_MAIN();
