// Whether this computer can hold the servo's 1 kHz SCHED_FIFO loop: the kernel's preemption
// model, the servo CPU's isolation and interrupts, its frequency governor and idle states, the
// process's memlock and rtprio limits, the kernel's RT throttling, and a short cyclictest-style
// measurement of the wake-up latency on the servo's CPU. Each item has a verdict, what was found,
// what is expected and what to change (docs/realtime_host.md). `hyq-servod --check-host` prints
// it; the systemd unit runs it before the loop (a refusal only with realtime.require_rt_host).
// Configuration time: reads /proc and /sys, allocates, may start a thread.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hyq::servo {

enum class HostVerdict : std::uint8_t {
  kOk,    // as a real-time host should be
  kWarn,  // the loop runs, with less margin than it should have
  kFail,  // the loop cannot run as configured (SCHED_FIFO refused, wake-ups past the budget)
};
/// "ok", "warn", "FAIL".
const char* ToString(HostVerdict v) noexcept;

struct HostItem {
  std::string name;      // "kernel preemption", ...
  HostVerdict verdict = HostVerdict::kOk;
  std::string found;     // what this host has
  std::string expected;  // what a real-time host has
  std::string fix;       // what to change (empty when ok)
};

struct HostCheckSettings {
  int cpu = -1;                  // the servo thread's CPU (realtime.cpu, resolved); -1: not pinned
  int priority = 80;             // its SCHED_FIFO priority (realtime.priority)
  bool lock_memory = true;       // realtime.lock_memory
  double period_s = 1e-3;        // the loop's period
  double budget_fraction = 0.9;  // deadline.budget_fraction
  double measure_s = 2.0;        // the wake-up measurement's length; 0: none
  /// Prefix of /proc and /sys (tests give a fake tree); empty: the host's. The process's own
  /// limits and capabilities come from the process, whatever the prefix.
  std::string root;
};

/// Every item, in the order of the header comment.
std::vector<HostItem> CheckHost(const HostCheckSettings& s);

/// One item per line block: "[ ok ] name: found", then for the others the expected value and
/// the fix, indented.
std::string FormatHostReport(const std::vector<HostItem>& items);

/// The worst verdict of the items (kOk for none).
HostVerdict Worst(const std::vector<HostItem>& items) noexcept;

/// A CPU list as the kernel writes it ("0-2,5"), parsed; malformed parts are skipped.
std::vector<int> ParseCpuList(const std::string& text);

/// The wake-up latencies of `n` absolute-time sleeps of `period_s` on the calling thread
/// (nanoseconds, sorted), as cyclictest measures them.
std::vector<std::int64_t> MeasureWakeups(double period_s, int n);

}  // namespace hyq::servo
