// CPU time of one HAL cycle (Read + Write) with 4 buses, 12 joints and the IMU, the device
// emulator answering over the in-process loopback buses. Reports the median and the 99th
// percentile of the per-cycle time (steady clock around Read + Write; the emulator's Poll is
// outside the timed region) and, separately, HAL + emulator together.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "tests/hal/hal_fixture.h"

namespace hyq::hal {
namespace {

void SetPlant(Emulator& emu, int i) {
  for (int j = 0; j < kNumJoints; ++j) emu.SetJointState(j, 0.001 * ((i + j) % 100), 0.1, 5.0);
  emu.SetImu({0.01, 0.02, 0.03}, {0.0, 0.0, 9.81});
}

void Percentiles(benchmark::State& state, std::vector<double>& ns) {
  if (ns.empty()) return;
  std::sort(ns.begin(), ns.end());
  state.counters["median_ns"] = ns[ns.size() / 2];
  state.counters["p99_ns"] = ns[std::min(ns.size() - 1, ns.size() * 99 / 100)];
  state.counters["max_ns"] = ns.back();
}

void BM_HalCycle(benchmark::State& state) {
  testing::HalRig rig;
  SetPlant(*rig.emu, 0);
  rig.BringUp();
  std::vector<double> ns;
  ns.reserve(1 << 20);
  int i = 0;
  std::uint64_t wkc_faults = 0;
  for (auto _ : state) {
    SetPlant(*rig.emu, ++i);
    const auto t0 = std::chrono::steady_clock::now();
    const HalStatus r = rig.hal->Read(rig.now_ns);
    for (auto& c : rig.hal->image().commands) c.torque_Nm = 2.0;
    const HalStatus w = rig.hal->Write(rig.now_ns);
    const auto t1 = std::chrono::steady_clock::now();
    wkc_faults += (r != HalStatus::kOk) + (w != HalStatus::kOk);
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(dt);
    if (ns.size() < ns.capacity()) ns.push_back(dt * 1e9);
    rig.emu->Poll(rig.now_ns);
    rig.now_ns += testing::kPeriodNs;
  }
  Percentiles(state, ns);
  state.counters["faults"] = static_cast<double>(wkc_faults);
}
BENCHMARK(BM_HalCycle)->UseManualTime();

void BM_HalAndEmulatorCycle(benchmark::State& state) {
  testing::HalRig rig;
  rig.BringUp();
  int i = 0;
  for (auto _ : state) {
    SetPlant(*rig.emu, ++i);
    benchmark::DoNotOptimize(rig.Step());
  }
}
BENCHMARK(BM_HalAndEmulatorCycle);

}  // namespace
}  // namespace hyq::hal

BENCHMARK_MAIN();
