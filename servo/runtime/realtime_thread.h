// The real-time set-up of the servo thread (house style §6, realtime_tools' lock_memory):
// mlockall, SCHED_FIFO, CPU affinity and a pre-faulted stack, each refusal reported by name with
// the capability or limit that is missing; and the absolute-time sleep of the real-time clock.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/config_key.h"

namespace hyq::servo {

/// RealtimeConfig::cpu: do not pin, or pin where two cores exist (ResolveCpu).
inline constexpr int kNoCpu = -1;
inline constexpr int kAutoCpu = -2;

struct RealtimeConfig {
  bool enabled = true;            // try SCHED_FIFO, affinity and mlockall (warn when refused)
  int priority = 80;              // SCHED_FIFO priority of the servo thread, 1..99
  int cpu = kNoCpu;               // pin the thread to this CPU; kNoCpu: do not pin; kAutoCpu:
                                  // see ResolveCpu
  bool lock_memory = true;        // mlockall(MCL_CURRENT | MCL_FUTURE)
  std::uint32_t prefault_stack_kib = 256;  // stack touched before the first cycle
  bool require_rt_host = false;   // hyq-servod --check-host refuses (exit 4) a host not fit for
                                  // real time (servo/runtime/host_check.h); else it only warns

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled)
                 .Doc("try SCHED_FIFO, affinity and mlockall (warn when refused)"));
    a->Visit(hal::Key("priority", &priority).In(1, 99).Doc("SCHED_FIFO priority of the servo thread"));
    a->Visit(hal::Key("cpu", &cpu).In(-1, 1023).Choices({{"auto", kAutoCpu}})
                 .Doc("pin the servo thread to this CPU; -1: do not pin; auto: where two cores exist"));
    a->Visit(hal::Key("lock_memory", &lock_memory).Doc("mlockall(MCL_CURRENT | MCL_FUTURE)"));
    a->Visit(hal::Key("prefault_stack_kib", &prefault_stack_kib).In(0, 8192).Unit("KiB")
                 .Doc("stack touched before the first cycle"));
    a->Visit(hal::Key("require_rt_host", &require_rt_host)
                 .Doc("hyq-servod --check-host exits 4 unless every item of the host check is ok "
                      "(docs/realtime_host.md); false: it warns only"));
  }
};

/// What the real-time set-up of the calling thread achieved; `warnings` name each refused
/// request and the capability or limit that is missing (RLIMIT_RTPRIO, CAP_SYS_NICE,
/// RLIMIT_MEMLOCK, CAP_IPC_LOCK).
struct RealtimeReport {
  bool fifo = false, pinned = false, locked = false;
  std::vector<std::string> warnings;
};
/// SCHED_FIFO at settings.priority, pinned to settings.cpu, mlockall, the stack pre-faulted.
/// Configuration time (allocates for the report).
RealtimeReport SetUpRealtimeThread(const RealtimeConfig& settings);

/// `cpu` as SetUpRealtimeThread takes it: kAutoCpu becomes `preferred` (taken modulo the CPUs
/// this process may run on, counted from the highest for a negative value: −1 the last one)
/// when the real-time clock runs (`realtime`) and at least two CPUs are allowed, so that the
/// servo thread (the last CPU) and hyq-sim's stepping thread (CPU 0) never share a core; and
/// kNoCpu otherwise (a lock-step run, or a single core). Any other value is returned as it is.
int ResolveCpu(int cpu, bool realtime, int preferred) noexcept;

/// Sleeps until CLOCK_MONOTONIC reaches t_ns (TIMER_ABSTIME; resumed after signals).
void SleepUntil(std::int64_t t_ns) noexcept;

}  // namespace hyq::servo
