// A fixed-size latency histogram for the real-time path: Add never allocates; percentiles are
// read off the bins (resolution: the bin width) for reports.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

namespace hyq::hal {

class LatencyHistogram {
 public:
  static constexpr std::size_t kBins = 1000;
  static constexpr std::int64_t kBinNs = 2'000;  // 2 µs bins up to 2 ms, then one overflow bin

  void Add(std::int64_t ns) noexcept {
    const std::int64_t v = std::max<std::int64_t>(ns, 0);
    const auto b = std::min<std::size_t>(static_cast<std::size_t>(v / kBinNs), kBins);
    ++bins_[b];
    ++count_;
    max_ = std::max(max_, v);
    sum_ += static_cast<double>(v);
  }
  std::uint64_t count() const noexcept { return count_; }
  std::int64_t max_ns() const noexcept { return max_; }
  double mean_ns() const noexcept { return count_ ? sum_ / static_cast<double>(count_) : 0.0; }
  /// The upper edge of the bin holding the p-quantile (p in [0, 1]); max_ns() past the last bin.
  std::int64_t Percentile(double p) const noexcept {
    if (count_ == 0) return 0;
    const auto target = static_cast<std::uint64_t>(p * static_cast<double>(count_ - 1)) + 1;
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < kBins; ++b) {
      seen += bins_[b];
      if (seen >= target) return std::min<std::int64_t>(static_cast<std::int64_t>(b + 1) * kBinNs, max_);
    }
    return max_;
  }
  std::uint64_t bin(std::size_t b) const noexcept { return bins_[b]; }

 private:
  std::array<std::uint64_t, kBins + 1> bins_{};
  std::uint64_t count_ = 0;
  std::int64_t max_ = 0;
  double sum_ = 0.0;
};

}  // namespace hyq::hal
