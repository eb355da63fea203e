// SYNC → all inputs received on the virtual bus (UDP multicast, 4 buses, 12 boards + IMU
// emulated in another thread), at 1 kHz, with the HAL's Read and Write in the loop.
//   tests/drivers/in_netns.sh build/release/tests/drivers/virtual_bus_benchmark
#include <algorithm>
#include <vector>

#include <benchmark/benchmark.h>

#include "tests/drivers/virtual_rig.h"

namespace hyq::testing {
namespace {

void BM_SyncToInputs(benchmark::State& state) {
  if (std::getenv("HYQ_NETNS") == nullptr) {
    state.SkipWithError("needs a private network namespace (tests/drivers/in_netns.sh)");
    return;
  }
  VirtualRig rig(43413);
  rig.BringUp();
  std::vector<double> us;
  us.reserve(100000);
  std::int64_t next = MonotonicNs();
  long timeouts = 0, wkc_faults = 0;
  for (auto _ : state) {
    next += 1'000'000;  // 1 kHz cadence
    timespec t{next / 1'000'000'000, next % 1'000'000'000};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
    const std::int64_t t0 = MonotonicNs();
    (void)rig.hal->Write(t0);
    if (!rig.WaitForInputs(13, 5'000'000)) ++timeouts;
    const std::int64_t t1 = MonotonicNs();
    if (rig.hal->Read(t1) != hal::HalStatus::kOk) ++wkc_faults;
    us.push_back(static_cast<double>(t1 - t0) / 1e3);
    state.SetIterationTime(static_cast<double>(t1 - t0) * 1e-9);
  }
  std::sort(us.begin(), us.end());
  auto pct = [&](double p) { return us[std::min(us.size() - 1, static_cast<std::size_t>(p * us.size()))]; };
  state.counters["p50_us"] = pct(0.5);
  state.counters["p99_us"] = pct(0.99);
  state.counters["max_us"] = us.back();
  state.counters["timeouts"] = static_cast<double>(timeouts);
  state.counters["wkc_faults"] = static_cast<double>(wkc_faults);
}
BENCHMARK(BM_SyncToInputs)->UseManualTime()->Iterations(3000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hyq::testing

BENCHMARK_MAIN();
