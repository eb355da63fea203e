#include "servo/runtime/realtime_thread.h"

#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <time.h>

#include <cstring>

namespace hyq::servo {

void SleepUntil(std::int64_t t_ns) noexcept {
  timespec t{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR) {
  }
}

int ResolveCpu(int cpu, bool realtime, int preferred) noexcept {
  if (cpu != kAutoCpu) return cpu;
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (!realtime || sched_getaffinity(0, sizeof allowed, &allowed) != 0) return kNoCpu;
  int ids[CPU_SETSIZE];
  int n = 0;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) ids[n++] = c;
  if (n < 2) return kNoCpu;
  return ids[((preferred % n) + n) % n];
}

namespace {

__attribute__((noinline)) void PrefaultStack(std::size_t bytes) {
  constexpr std::size_t kChunk = 16 * 1024;
  unsigned char buf[kChunk];
  std::memset(buf, 0, sizeof buf);
  asm volatile("" : : "r"(buf) : "memory");  // keep the writes: they are the point
  if (bytes > kChunk) PrefaultStack(bytes - kChunk);
}

std::string Limit(int resource) {
  rlimit r{};
  if (getrlimit(resource, &r) != 0) return "unknown";
  return r.rlim_cur == RLIM_INFINITY ? "unlimited" : std::to_string(r.rlim_cur);
}

}  // namespace

RealtimeReport SetUpRealtimeThread(const RealtimeConfig& s) {
  RealtimeReport r;
  if (!s.enabled) {
    r.warnings.push_back("real-time set-up disabled by configuration (realtime.enabled: false)");
    return r;
  }
  if (s.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      r.locked = true;
    } else {
      const int e = errno;
      r.warnings.push_back(std::string("mlockall refused (") + std::strerror(e) +
                           "): memory may be paged out; needs CAP_IPC_LOCK or RLIMIT_MEMLOCK "
                           "(now " + Limit(RLIMIT_MEMLOCK) + " bytes) >= the process size");
    }
  }
  sched_param sp{};
  sp.sched_priority = s.priority;
  if (const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp); e == 0) {
    r.fifo = true;
  } else {
    r.warnings.push_back("SCHED_FIFO priority " + std::to_string(s.priority) + " refused (" +
                         std::strerror(e) + "): the servo thread runs SCHED_OTHER; needs "
                         "CAP_SYS_NICE or RLIMIT_RTPRIO >= " + std::to_string(s.priority) +
                         " (now " + Limit(RLIMIT_RTPRIO) + ")");
  }
  if (s.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(s.cpu, &set);
    if (const int e = pthread_setaffinity_np(pthread_self(), sizeof set, &set); e == 0)
      r.pinned = true;
    else
      r.warnings.push_back("pinning to CPU " + std::to_string(s.cpu) + " refused (" +
                           std::strerror(e) + "): the CPU may not exist or not be allowed");
  }
  PrefaultStack(static_cast<std::size_t>(s.prefault_stack_kib) * 1024);
  return r;
}

}  // namespace hyq::servo
