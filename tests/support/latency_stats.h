// Per-call latency percentiles for Google Benchmark loops: time each call with the steady clock,
// then publish p50 / p99 / p99.9 / max (ns) as counters, so benchmarks report tails, not only
// the mean per batch.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

#include <benchmark/benchmark.h>

namespace hyq::testing {

class LatencyRecorder {
 public:
  explicit LatencyRecorder(std::size_t capacity) { samples_.reserve(capacity); }

  /// Times f() and keeps the sample; returns it (ns).
  template <class F>
  double Time(F&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const auto t1 = std::chrono::steady_clock::now();
    const double ns = std::chrono::duration<double, std::nano>(t1 - t0).count();
    if (samples_.size() < samples_.capacity()) samples_.push_back(ns);
    return ns;
  }

  void Publish(benchmark::State* state) {
    if (samples_.empty()) return;
    std::sort(samples_.begin(), samples_.end());
    state->counters["p50_ns"] = Percentile(samples_, 0.50);
    state->counters["p99_ns"] = Percentile(samples_, 0.99);
    state->counters["p999_ns"] = Percentile(samples_, 0.999);
    state->counters["max_ns"] = samples_.back();
  }

  /// The same percentiles of a loop over a fixed sequence of inputs, each input's fastest call:
  /// what the inputs themselves cost (more iterations, more work) without the machine's
  /// interruptions, which strike the slowest calls of any code alike. Published as
  /// input_p50_ns and input_p999_ns.
  static void PublishPerInput(std::vector<double> fastest, benchmark::State* state) {
    if (fastest.empty()) return;
    std::sort(fastest.begin(), fastest.end());
    state->counters["input_p50_ns"] = Percentile(fastest, 0.50);
    state->counters["input_p999_ns"] = Percentile(fastest, 0.999);
  }

 private:
  // the p-quantile of sorted, non-empty samples (the sample at rank ⌊p n⌋)
  static double Percentile(const std::vector<double>& sorted, double p) {
    return sorted[std::min(sorted.size() - 1,
                           static_cast<std::size_t>(p * static_cast<double>(sorted.size())))];
  }

  std::vector<double> samples_;
};

}  // namespace hyq::testing
