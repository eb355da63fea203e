// The host check (servo/runtime/host_check.h) on fake /proc and /sys trees: a real-time host
// passes every item, a desktop kernel gets each warning with the fix that names the servo CPU;
// the CPU lists as the kernel writes them; the wake-up measurement's samples.
#include "servo/runtime/host_check.h"

#include <time.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hyq::servo {
namespace {

namespace fs = std::filesystem;

// a fake root under the test's temporary directory; Put writes one file
struct FakeRoot {
  explicit FakeRoot(const std::string& name)
      : dir(fs::temp_directory_path() / ("hyq_host_check_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(dir);
  }
  ~FakeRoot() { fs::remove_all(dir); }
  void Put(const std::string& path, const std::string& text) const {
    const fs::path p = dir / path;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text << "\n";
  }
  // one of CPU `cpu`'s idle states as cpuidle shows it
  void PutIdleState(int cpu, int state, const std::string& name, int latency_us, bool disabled) const {
    const std::string d = "sys/devices/system/cpu/cpu" + std::to_string(cpu) + "/cpuidle/state" +
                          std::to_string(state) + "/";
    Put(d + "name", name);
    Put(d + "latency", std::to_string(latency_us));
    Put(d + "disable", disabled ? "1" : "0");
  }
  HostCheckSettings Settings(int cpu) const {
    HostCheckSettings s;
    s.cpu = cpu;
    s.measure_s = 0.0;  // the process's own wake-ups are not the fake host's
    s.root = dir.string();
    return s;
  }
  fs::path dir;
};

const HostItem& Item(const std::vector<HostItem>& items, const std::string& name) {
  for (const HostItem& it : items)
    if (it.name == name) return it;
  static const HostItem none;
  ADD_FAILURE() << "no item " << name;
  return none;
}

TEST(HostCheck, CpuListsAsTheKernelWritesThem) {
  EXPECT_EQ(ParseCpuList("0-2,5"), (std::vector<int>{0, 1, 2, 5}));
  EXPECT_EQ(ParseCpuList("3"), (std::vector<int>{3}));
  EXPECT_TRUE(ParseCpuList("").empty());
  EXPECT_TRUE(ParseCpuList("(null)").empty());
  EXPECT_EQ(ParseCpuList("1,x,4-3,7"), (std::vector<int>{1, 7})) << "malformed parts skipped";
}

TEST(HostCheck, ARealTimeHostPassesEveryHostItem) {
  FakeRoot r("rt");
  r.Put("sys/kernel/realtime", "1");
  r.Put("proc/sys/kernel/version", "#1 SMP PREEMPT_RT Debian 6.1.115-1");
  r.Put("sys/devices/system/cpu/isolated", "1");
  r.Put("sys/devices/system/cpu/nohz_full", "1");
  r.Put("proc/irq/10/smp_affinity_list", "0");
  r.Put("proc/irq/27/smp_affinity_list", "0,2-3");
  r.Put("sys/devices/system/cpu/cpu1/cpufreq/scaling_governor", "performance");
  r.PutIdleState(1, 0, "POLL", 0, false);
  r.PutIdleState(1, 1, "C6", 133, true);
  r.Put("proc/sys/kernel/sched_rt_runtime_us", "950000");
  r.Put("proc/sys/kernel/sched_rt_period_us", "1000000");
  const std::vector<HostItem> items = CheckHost(r.Settings(1));
  const std::string report = FormatHostReport(items);
  std::printf("%s", report.c_str());
  for (const char* name : {"kernel preemption", "servo CPU isolation", "servo CPU interrupts",
                           "frequency governor", "idle states", "RT throttling"}) {
    EXPECT_EQ(Item(items, name).verdict, HostVerdict::kOk) << name << ": " << Item(items, name).found;
    EXPECT_TRUE(Item(items, name).fix.empty()) << name;
  }
  EXPECT_NE(Item(items, "RT throttling").found.find("95 %"), std::string::npos);
  EXPECT_EQ(items.size(), 8u) << "no wake-up item without a measurement";
}

TEST(HostCheck, ADesktopKernelGetsEachFixForTheServoCpu) {
  FakeRoot r("desktop");
  r.Put("proc/sys/kernel/version", "#1 SMP PREEMPT_DYNAMIC Debian 6.1.115-1");
  r.Put("sys/devices/system/cpu/isolated", "");
  r.Put("sys/devices/system/cpu/nohz_full", "(null)");
  r.Put("proc/irq/10/smp_affinity_list", "0-3");
  r.Put("proc/irq/44/smp_affinity_list", "1");
  r.Put("proc/irq/45/smp_affinity_list", "0");
  r.Put("sys/devices/system/cpu/cpu1/cpufreq/scaling_governor", "schedutil");
  r.PutIdleState(1, 2, "C6", 133, false);
  r.Put("proc/sys/kernel/sched_rt_runtime_us", "500000");
  r.Put("proc/sys/kernel/sched_rt_period_us", "1000000");
  const std::vector<HostItem> items = CheckHost(r.Settings(1));
  std::printf("%s", FormatHostReport(items).c_str());
  const auto warns = [&](const char* name, const char* found, const char* fix) {
    const HostItem& it = Item(items, name);
    EXPECT_EQ(it.verdict, HostVerdict::kWarn) << name;
    EXPECT_NE(it.found.find(found), std::string::npos) << name << ": " << it.found;
    EXPECT_NE(it.fix.find(fix), std::string::npos) << name << ": " << it.fix;
    EXPECT_FALSE(it.expected.empty()) << name;
  };
  warns("kernel preemption", "PREEMPT_DYNAMIC", "linux-image-rt-amd64");
  warns("servo CPU isolation", "CPU 1 not isolated", "isolcpus=1 nohz_full=1");
  warns("servo CPU interrupts", "2 device interrupts may run on CPU 1 (IRQ 10,44)",
        "IRQBALANCE_BANNED_CPULIST=1");
  warns("frequency governor", "schedutil", "frequency-set -g performance");
  warns("idle states", "C6 (exit 133 µs)", "idle-set -D 10");
  warns("RT throttling", "50 %", "sched_rt_runtime_us=950000");
  EXPECT_EQ(Worst(items), std::max(HostVerdict::kWarn, Item(items, "rtprio limit").verdict));
  // not pinned: said, with the key to set
  const std::vector<HostItem> loose = CheckHost(r.Settings(-1));
  EXPECT_EQ(Item(loose, "servo CPU isolation").verdict, HostVerdict::kWarn);
  EXPECT_NE(Item(loose, "servo CPU isolation").fix.find("realtime.cpu"), std::string::npos);
}

// a host without cpufreq or cpuidle (a VM): nothing to change there
TEST(HostCheck, NoCpufreqOrCpuidleIsNothingToChange) {
  FakeRoot r("vm");
  r.Put("proc/sys/kernel/sched_rt_runtime_us", "-1");
  const std::vector<HostItem> items = CheckHost(r.Settings(0));
  EXPECT_EQ(Item(items, "frequency governor").verdict, HostVerdict::kOk);
  EXPECT_NE(Item(items, "frequency governor").found.find("no cpufreq"), std::string::npos);
  EXPECT_EQ(Item(items, "idle states").verdict, HostVerdict::kOk);
  EXPECT_EQ(Item(items, "RT throttling").verdict, HostVerdict::kOk);
  EXPECT_NE(Item(items, "RT throttling").found.find("off"), std::string::npos);
}

TEST(HostCheck, WakeupsAreAbsoluteSleepsOfOnePeriod) {
  timespec a{}, b{};
  clock_gettime(CLOCK_MONOTONIC, &a);
  const std::vector<std::int64_t> lat = MeasureWakeups(1e-3, 50);
  clock_gettime(CLOCK_MONOTONIC, &b);
  const double took = static_cast<double>(b.tv_sec - a.tv_sec) + 1e-9 * static_cast<double>(b.tv_nsec - a.tv_nsec);
  ASSERT_EQ(lat.size(), 50u);
  EXPECT_TRUE(std::is_sorted(lat.begin(), lat.end()));
  EXPECT_GE(lat.front(), 0);
  EXPECT_GE(took, 0.050) << "50 periods of 1 ms, on absolute deadlines";
  std::printf("50 wake-ups: median %.0f µs, max %.0f µs, %.1f ms in all\n", 1e-3 * static_cast<double>(lat[25]),
              1e-3 * static_cast<double>(lat.back()), 1e3 * took);
}

}  // namespace
}  // namespace hyq::servo
