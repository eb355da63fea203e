#include "servo/runtime/host_check.h"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace hyq::servo {
namespace {

// Verdict thresholds of the wake-up measurement, as fractions of the period: the deadline budget
// (0.9 of it) must hold a wake-up plus the cycle's own work (p99 ~0.13 ms, worst ~0.3 ms on the
// reference machine, docs/benchmarks.md): a worst wake-up of 0.1 period leaves half the budget,
// one past 0.3 period leaves nothing for a slow cycle.
constexpr double kWakeupOk = 0.1, kWakeupWarn = 0.3;
// An idle state whose exit takes longer than this (µs) adds to every wake-up from it.
constexpr int kDeepIdleUs = 10;
constexpr int kCapIpcLock = 14, kCapSysNice = 23;  // linux/capability.h

HostItem Named(const char* name) {
  HostItem it;
  it.name = name;
  return it;
}

bool ReadFile(const std::string& path, std::string* out) {
  std::ifstream f(path);
  if (!f) return false;
  std::stringstream ss;
  ss << f.rdbuf();
  *out = ss.str();
  while (!out->empty() && (out->back() == '\n' || out->back() == ' ')) out->pop_back();
  return true;
}

std::string CpuDir(const std::string& root, int cpu) {
  return root + "/sys/devices/system/cpu/cpu" + std::to_string(std::max(cpu, 0));
}

std::string ListText(const std::vector<int>& cpus) {
  if (cpus.empty()) return "none";
  std::string s;
  for (const int c : cpus) {
    if (!s.empty()) s += ',';
    s += std::to_string(c);
  }
  return s;
}

bool Has(const std::vector<int>& cpus, int cpu) {
  return std::find(cpus.begin(), cpus.end(), cpu) != cpus.end();
}

// The effective capabilities of this process (/proc/self/status, CapEff), 0 when unreadable.
std::uint64_t EffectiveCaps() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("CapEff:", 0) == 0) return std::strtoull(line.c_str() + 7, nullptr, 16);
  return 0;
}

std::string Limit(rlim_t v, const char* unit) {
  if (v == RLIM_INFINITY) return "unlimited";
  return std::to_string(static_cast<unsigned long long>(v)) + unit;
}

HostItem Preemption(const std::string& root) {
  HostItem it = Named("kernel preemption");
  std::string rt, version;
  const bool flag = ReadFile(root + "/sys/kernel/realtime", &rt) && rt == "1";
  (void)ReadFile(root + "/proc/sys/kernel/version", &version);
  if (flag || version.find("PREEMPT_RT") != std::string::npos ||
      version.find("PREEMPT RT") != std::string::npos) {
    it.found = "PREEMPT_RT (" + (flag ? std::string("/sys/kernel/realtime = 1") : version) + ")";
    return it;
  }
  it.verdict = HostVerdict::kWarn;
  it.found = "not PREEMPT_RT (kernel version '" + (version.empty() ? "unknown" : version) + "')";
  it.expected = "a PREEMPT_RT kernel (/sys/kernel/realtime = 1)";
  it.fix = "apt install linux-image-rt-amd64, then boot it (docs/realtime_host.md)";
  return it;
}

HostItem Isolation(const std::string& root, int cpu) {
  HostItem it = Named("servo CPU isolation");
  std::string iso, nohz;
  (void)ReadFile(root + "/sys/devices/system/cpu/isolated", &iso);
  (void)ReadFile(root + "/sys/devices/system/cpu/nohz_full", &nohz);
  const std::vector<int> isolated = ParseCpuList(iso), tickless = ParseCpuList(nohz);
  if (cpu < 0) {
    it.verdict = HostVerdict::kWarn;
    it.found = "the servo thread is not pinned (realtime.cpu: -1); isolated CPUs: " + ListText(isolated);
    it.expected = "the servo thread pinned to an isolated CPU";
    it.fix = "realtime.cpu: an isolated CPU (isolcpus=, docs/realtime_host.md)";
    return it;
  }
  const std::string c = std::to_string(cpu);
  it.found = "CPU " + c + (Has(isolated, cpu) ? " isolated" : " not isolated") + " (isolated: " +
             ListText(isolated) + "; nohz_full: " + ListText(tickless) + ")";
  if (Has(isolated, cpu) && Has(tickless, cpu)) return it;
  it.verdict = HostVerdict::kWarn;
  it.expected = "CPU " + c + " in isolcpus and nohz_full (no other tasks, no scheduler tick)";
  it.fix = "isolcpus=" + c + " nohz_full=" + c + " rcu_nocbs=" + c +
           " in GRUB_CMDLINE_LINUX (/etc/default/grub), update-grub, reboot";
  return it;
}

HostItem Interrupts(const std::string& root, int cpu) {
  HostItem it = Named("servo CPU interrupts");
  if (cpu < 0) {
    it.verdict = HostVerdict::kWarn;
    it.found = "the servo thread is not pinned: any CPU's interrupts reach it";
    it.expected = "the servo thread on a CPU no device interrupt is routed to";
    it.fix = "realtime.cpu, then irqaffinity= (docs/realtime_host.md)";
    return it;
  }
  std::vector<int> irqs;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(root + "/proc/irq", ec)) {
    const std::string n = e.path().filename().string();
    if (n.empty() || n.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string list;
    if (ReadFile(e.path().string() + "/smp_affinity_list", &list) && Has(ParseCpuList(list), cpu))
      irqs.push_back(std::stoi(n));
  }
  std::sort(irqs.begin(), irqs.end());
  const std::string c = std::to_string(cpu);
  if (irqs.empty()) {
    it.found = "no device interrupt may run on CPU " + c;
    return it;
  }
  std::string some;
  for (std::size_t i = 0; i < irqs.size() && i < 8; ++i) {
    if (i > 0) some += ',';
    some += std::to_string(irqs[i]);
  }
  if (irqs.size() > 8) some += ",...";
  it.verdict = HostVerdict::kWarn;
  it.found = std::to_string(irqs.size()) + " device interrupts may run on CPU " + c + " (IRQ " + some + ")";
  it.expected = "none on the servo CPU (the CAN adapter's on a neighbour)";
  it.fix = "irqaffinity=<the other CPUs> on the kernel command line; with irqbalance, "
           "IRQBALANCE_BANNED_CPULIST=" + c + " in /etc/default/irqbalance; or echo <CPUs> > "
           "/proc/irq/N/smp_affinity_list per IRQ";
  return it;
}

HostItem Governor(const std::string& root, int cpu) {
  HostItem it = Named("frequency governor");
  std::string g;
  const std::string c = std::to_string(std::max(cpu, 0));
  if (!ReadFile(CpuDir(root, cpu) + "/cpufreq/scaling_governor", &g)) {
    it.found = "no cpufreq on CPU " + c + " (a fixed frequency, or a VM's)";
    return it;
  }
  it.found = "CPU " + c + ": " + g;
  if (g == "performance") return it;
  it.verdict = HostVerdict::kWarn;
  it.expected = "performance (no frequency ramps under a bursty 1 kHz load)";
  it.fix = "cpupower -c " + c + " frequency-set -g performance (package linux-cpupower), or "
           "cpufreq.default_governor=performance on the kernel command line";
  return it;
}

HostItem IdleStates(const std::string& root, int cpu) {
  HostItem it = Named("idle states");
  const std::string c = std::to_string(std::max(cpu, 0));
  std::string deep;
  int states = 0;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(CpuDir(root, cpu) + "/cpuidle", ec)) {
    if (e.path().filename().string().rfind("state", 0) != 0) continue;
    std::string name, latency, disable;
    if (!ReadFile(e.path().string() + "/latency", &latency)) continue;
    (void)ReadFile(e.path().string() + "/name", &name);
    (void)ReadFile(e.path().string() + "/disable", &disable);
    ++states;
    if (disable != "1" && std::atoi(latency.c_str()) > kDeepIdleUs) {
      if (!deep.empty()) deep += ", ";
      deep += name;
      deep += " (exit " + latency + " µs)";
    }
  }
  if (states == 0) {
    it.found = "no cpuidle states on CPU " + c;
    return it;
  }
  if (deep.empty()) {
    it.found = "CPU " + c + ": no enabled idle state exits slower than " + std::to_string(kDeepIdleUs) + " µs";
    return it;
  }
  it.verdict = HostVerdict::kWarn;
  it.found = "CPU " + c + " may sleep in " + deep;
  it.expected = "no idle state slower than " + std::to_string(kDeepIdleUs) + " µs to leave";
  it.fix = "cpupower -c " + c + " idle-set -D " + std::to_string(kDeepIdleUs) +
           ", or processor.max_cstate=1 intel_idle.max_cstate=1 on the kernel command line";
  return it;
}

// A resource limit of this process and the capability that overrides it, as one line.
struct LimitState {
  rlim_t cur = 0;
  bool cap = false;
  std::string text;
};
LimitState ReadLimit(int resource, const char* name, const char* unit, int cap_bit, const char* cap) {
  rlimit r{};
  getrlimit(resource, &r);
  LimitState l;
  l.cur = r.rlim_cur;
  l.cap = (EffectiveCaps() >> cap_bit) & 1u;
  l.text = std::string(name) + " " + Limit(l.cur, unit) + (l.cap ? ", " : ", no ") + cap;
  return l;
}

HostItem Memlock(bool lock_memory) {
  HostItem it = Named("memlock limit");
  const LimitState l = ReadLimit(RLIMIT_MEMLOCK, "RLIMIT_MEMLOCK", " B", kCapIpcLock, "CAP_IPC_LOCK");
  it.found = l.text;
  if (!lock_memory) {
    it.verdict = HostVerdict::kWarn;
    it.found += "; realtime.lock_memory is false";
    it.expected = "memory locked (no page faults in the loop)";
    it.fix = "realtime.lock_memory: true";
    return it;
  }
  if (l.cur == RLIM_INFINITY || l.cap) return it;
  it.verdict = HostVerdict::kWarn;
  it.expected = "unlimited or CAP_IPC_LOCK: mlockall locks every mapping of the daemon";
  it.fix = "LimitMEMLOCK=infinity in the unit (as shipped), or 'hyq - memlock unlimited' in "
           "/etc/security/limits.d/hyq.conf";
  return it;
}

HostItem RtPrio(int priority) {
  HostItem it = Named("rtprio limit");
  const LimitState l = ReadLimit(RLIMIT_RTPRIO, "RLIMIT_RTPRIO", "", kCapSysNice, "CAP_SYS_NICE");
  it.found = l.text;
  if (l.cap || l.cur == RLIM_INFINITY || l.cur >= static_cast<rlim_t>(priority)) return it;
  it.verdict = HostVerdict::kFail;
  it.expected = "SCHED_FIFO " + std::to_string(priority) + " allowed (RLIMIT_RTPRIO >= " +
                std::to_string(priority) + " or CAP_SYS_NICE)";
  it.fix = "LimitRTPRIO=90 in the unit (as shipped), or 'hyq - rtprio 90' in "
           "/etc/security/limits.d/hyq.conf";
  return it;
}

HostItem RtThrottling(const std::string& root) {
  HostItem it = Named("RT throttling");
  std::string runtime, period;
  if (!ReadFile(root + "/proc/sys/kernel/sched_rt_runtime_us", &runtime)) {
    it.found = "sched_rt_runtime_us unreadable";
    return it;
  }
  (void)ReadFile(root + "/proc/sys/kernel/sched_rt_period_us", &period);
  const long rt = std::atol(runtime.c_str()), per = std::max(1L, std::atol(period.c_str()));
  if (rt < 0) {
    it.found = "off (sched_rt_runtime_us = -1)";
    return it;
  }
  const double share = static_cast<double>(rt) / static_cast<double>(per);
  char f[128];
  std::snprintf(f, sizeof f, "RT tasks get %.0f %% of each %.2f s (sched_rt_runtime_us = %ld)",
                100.0 * share, 1e-6 * static_cast<double>(per), rt);
  it.found = f;
  if (share >= 0.95) return it;
  it.verdict = HostVerdict::kWarn;
  it.expected = "at least the default 95 % (or -1 with an isolated servo CPU)";
  it.fix = "sysctl kernel.sched_rt_runtime_us=950000 (or -1), in /etc/sysctl.d/hyq.conf";
  return it;
}

HostItem Wakeups(const HostCheckSettings& s) {
  HostItem it = Named("wake-up latency");
  const int n = std::max(1, static_cast<int>(s.measure_s / s.period_s));
  std::vector<std::int64_t> lat;
  std::string how;
  std::thread t([&] {
    if (s.cpu >= 0) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(s.cpu, &set);
      if (pthread_setaffinity_np(pthread_self(), sizeof set, &set) != 0)
        how += "; not pinned to CPU " + std::to_string(s.cpu);
    }
    sched_param p{};
    p.sched_priority = s.priority;
    const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    if (err != 0) how += std::string("; SCHED_OTHER (SCHED_FIFO refused: ") + std::strerror(err) + ")";
    lat = MeasureWakeups(s.period_s, n);
  });
  t.join();
  const auto at = [&](double q) {
    return 1e-3 * static_cast<double>(lat[std::min(lat.size() - 1, static_cast<std::size_t>(q * static_cast<double>(lat.size())))]);
  };
  const double max_us = 1e-3 * static_cast<double>(lat.back());
  const double period_us = 1e6 * s.period_s;
  char f[256];
  std::snprintf(f, sizeof f,
                "%d sleeps of %.0f µs on CPU %s at SCHED_FIFO %d: median %.0f, p99 %.0f, p99.9 %.0f, max %.0f µs%s",
                n, period_us, s.cpu >= 0 ? std::to_string(s.cpu).c_str() : "any", s.priority, at(0.5),
                at(0.99), at(0.999), max_us, how.c_str());
  it.found = f;
  std::snprintf(f, sizeof f, "max <= %.0f µs (0.1 period: half the %.0f µs budget left for the cycle)",
                kWakeupOk * period_us, s.budget_fraction * period_us);
  it.expected = f;
  if (max_us <= kWakeupOk * period_us && how.empty()) {
    it.expected.clear();
    return it;
  }
  it.verdict = max_us > kWakeupWarn * period_us ? HostVerdict::kFail : HostVerdict::kWarn;
  it.fix = "the items above (a PREEMPT_RT kernel, an isolated servo CPU without interrupts, the "
           "performance governor, no deep idle states); compare with cyclictest -m -p 80 -a " +
           (s.cpu >= 0 ? std::to_string(s.cpu) : std::string("1")) + " -i 1000 -D 60 (rt-tests)";
  return it;
}

}  // namespace

const char* ToString(HostVerdict v) noexcept {
  switch (v) {
    case HostVerdict::kOk: return "ok";
    case HostVerdict::kWarn: return "warn";
    case HostVerdict::kFail: return "FAIL";
  }
  return "?";
}

std::vector<int> ParseCpuList(const std::string& text) {
  std::vector<int> cpus;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    int a = 0, b = 0;
    char dash = 0;
    std::stringstream ps(part);
    if (!(ps >> a)) continue;
    if (ps >> dash && dash == '-' && ps >> b) {
      if (b < a || b - a > 4096) continue;
      for (int c = a; c <= b; ++c) cpus.push_back(c);
    } else {
      cpus.push_back(a);
    }
  }
  return cpus;
}

std::vector<std::int64_t> MeasureWakeups(double period_s, int n) {
  std::vector<std::int64_t> lat;
  lat.reserve(static_cast<std::size_t>(n));
  const auto period_ns = static_cast<std::int64_t>(period_s * 1e9);
  auto now = [] {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
  };
  std::int64_t next = now() + period_ns;
  for (int i = 0; i < n; ++i) {
    timespec ts{static_cast<time_t>(next / 1000000000), static_cast<long>(next % 1000000000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    lat.push_back(std::max<std::int64_t>(0, now() - next));
    next += period_ns;
  }
  std::sort(lat.begin(), lat.end());
  return lat;
}

std::vector<HostItem> CheckHost(const HostCheckSettings& s) {
  std::vector<HostItem> items;
  items.push_back(Preemption(s.root));
  items.push_back(Isolation(s.root, s.cpu));
  items.push_back(Interrupts(s.root, s.cpu));
  items.push_back(Governor(s.root, s.cpu));
  items.push_back(IdleStates(s.root, s.cpu));
  items.push_back(Memlock(s.lock_memory));
  items.push_back(RtPrio(s.priority));
  items.push_back(RtThrottling(s.root));
  if (s.measure_s > 0.0 && s.period_s > 0.0) items.push_back(Wakeups(s));
  return items;
}

std::string FormatHostReport(const std::vector<HostItem>& items) {
  std::string out;
  for (const HostItem& it : items) {
    const char* tag = it.verdict == HostVerdict::kOk ? "[ ok ]" : it.verdict == HostVerdict::kWarn ? "[warn]" : "[FAIL]";
    out += tag;
    out += ' ';
    out += it.name;
    out += ": ";
    out += it.found;
    out += '\n';
    if (!it.expected.empty()) out += "       expected: " + it.expected + "\n";
    if (!it.fix.empty()) out += "       fix: " + it.fix + "\n";
  }
  return out;
}

HostVerdict Worst(const std::vector<HostItem>& items) noexcept {
  HostVerdict w = HostVerdict::kOk;
  for (const HostItem& it : items) w = std::max(w, it.verdict);
  return w;
}

}  // namespace hyq::servo
