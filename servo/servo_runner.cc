#include "servo/servo_runner.h"

#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cstring>

#include "hal/protocol.h"

namespace hyq::servo {

std::int64_t MonotonicNs() noexcept {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

namespace {

void SleepUntil(std::int64_t t_ns) noexcept {
  timespec t{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR) {
  }
}

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

RealtimeReport SetUpRealtimeThread(const RealtimeSettings& s) {
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

// --- lock-step ---------------------------------------------------------------------------------

bool WaitForInputs(const hal::Hal& hal, std::span<LockstepChannel* const> channels,
                   std::int64_t timeout_ns, std::int64_t idle_ns) noexcept {
  int expected = 0;
  for (std::size_t b = 0; b < hal.num_buses(); ++b)
    for (const auto& d : hal.bus(b).devices()) expected += d.expect_inputs ? 1 : 0;
  std::array<pollfd, hal::kMaxBuses> fds{};
  std::size_t nfds = 0;
  for (LockstepChannel* c : channels)
    if (c->poll_fd() >= 0 && nfds < fds.size()) fds[nfds++] = {c->poll_fd(), POLLIN, 0};
  // nothing owed (devices below SAFE-OP): only a moment for NMT answers and heartbeats
  const std::int64_t end = MonotonicNs() + (expected == 0 ? std::min(timeout_ns, idle_ns) : timeout_ns);
  for (;;) {
    int got = 0;
    for (LockstepChannel* c : channels) got += c->Pump();
    if (expected > 0 && got >= expected) return true;
    const std::int64_t left = end - MonotonicNs();
    if (left <= 0) return expected == 0;
    (void)poll(fds.data(), nfds, static_cast<int>(std::max<std::int64_t>(left / 1'000'000, 1)));
  }
}

std::int64_t BringUp(hal::Hal& hal, const ServoConfig& config,
                     std::span<LockstepChannel* const> channels) {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t now = config.clock == ClockMode::kLockstep ? 0 : MonotonicNs();
  hal::RunBringUp(hal, hal::DeviceState::kOp, now, [&] {
    if (config.clock == ClockMode::kLockstep) {
      // devices that owe no TPDO yet answer NMT commands: give them a moment of wall time
      (void)WaitForInputs(hal, channels, 200'000'000, 20'000'000);
      now += period;
    } else {
      now += period;
      SleepUntil(now);
    }
    return now;
  });
  return now;
}

void RunRealtime(ServoLoop& loop, const ServoConfig& config, std::int64_t start_ns) noexcept {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t next = start_ns;
  while (!loop.finished()) {
    next += period;
    SleepUntil(next);
    const std::int64_t woke = MonotonicNs();
    loop.Cycle(next, woke - next);
    const std::int64_t end = MonotonicNs();
    if (end > next + period) {  // overran the next wake-up: skip the periods already lost
      const std::int64_t lost = (end - next) / period;
      loop.CountSkipped(static_cast<std::uint64_t>(lost));
      next += lost * period;
    }
  }
}

void RunLockstep(ServoLoop& loop, const hal::Hal& hal, const ServoConfig& config,
                 std::span<LockstepChannel* const> channels, std::int64_t start_ns) noexcept {
  const auto period = static_cast<std::int64_t>(config.period_s() * 1e9);
  std::int64_t now = start_ns;
  // a device that stopped answering would make every cycle wait the full timeout: after a cycle
  // came up short, wait only briefly for the next thousand cycles
  int short_waits = 0;
  const auto long_ns = static_cast<std::int64_t>(config.lockstep_timeout_s * 1e9);
  const auto short_ns = static_cast<std::int64_t>(config.lockstep_short_timeout_s * 1e9);
  while (!loop.finished()) {
    now += period;
    loop.Cycle(now, 0);
    const bool complete = WaitForInputs(hal, channels, short_waits > 0 ? short_ns : long_ns,
                                        std::min<std::int64_t>(short_ns, 1'000'000));
    if (!complete) short_waits = 1000;
    else if (short_waits > 0) --short_waits;
  }
}

}  // namespace hyq::servo
