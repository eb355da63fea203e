#include "sim/realtime_runner.h"

#include <poll.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <stdexcept>

#include "hal/clock.h"
#include "sim/sync_phase_lock.h"

namespace hyq::sim {

RealtimeRunner::RealtimeRunner(SimulatedRobot* robot) : robot_(*robot), bus_(robot) {}

std::uint64_t RealtimeRunner::Run(const std::atomic<bool>& stop, double duration_s,
                                  const BusThreadConfig& bus) {
  const std::int64_t period_ns = robot_.period_ns();
  const int tfd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (tfd < 0) throw std::runtime_error("simulated robot: timerfd_create failed");
  // one-shot absolute deadlines, each set after the last step: the phase lock moves them
  const auto arm = [tfd](std::int64_t at_ns) {
    itimerspec its{};
    its.it_value = {static_cast<time_t>(at_ns / 1'000'000'000), static_cast<long>(at_ns % 1'000'000'000)};
    return timerfd_settime(tfd, TFD_TIMER_ABSTIME, &its, nullptr) == 0;
  };
  const std::int64_t t0 = MonotonicNs() + period_ns;
  if (!arm(t0)) {
    close(tfd);
    throw std::runtime_error("simulated robot: timerfd_settime failed");
  }
  const SyncPhaseLock lock{.period_ns = period_ns, .phase_ns = robot_.config().sync_phase_ns};
  std::array<pollfd, hal::kMaxBuses + 1> fds{};
  nfds_t n = 0;
  fds[n++] = {tfd, POLLIN, 0};
  if (!bus.enabled)
    for (std::size_t b = 0; b < robot_.num_buses(); ++b)
      if (robot_.channel_poll_fd(b) >= 0) fds[n++] = {robot_.channel_poll_fd(b), POLLIN, 0};
  bus_.SetStepDue(t0);
  robot_.ForgetLastSync();
  // behind after a stall (of this host, not of the boards), the boards answer only the newest
  // SYNC: the master discards answers to older ones, and each costs a datagram per board
  robot_.emulator().SetAnswerNewestSyncOnly(true);
  if (bus.enabled) bus_.Start(bus.setup);
  const auto end_steps = duration_s > 0
                             ? static_cast<std::uint64_t>(std::llround(duration_s * 1e9 / static_cast<double>(period_ns)))
                             : UINT64_MAX;
  const std::uint64_t start = robot_.counters().steps;
  std::int64_t due_ns = t0;  // when the next step is due
  std::uint64_t syncs_seen = 0;
  // without the bus thread, this thread answers: it notes when a new SYNC came, for the lock
  const auto poll_answering = [&](std::int64_t now) {
    robot_.Poll(now);
    (void)robot_.NoteNewSyncs(now, &syncs_seen);
  };
  while (!stop.load(std::memory_order_relaxed) && robot_.counters().steps < end_steps) {
    // channels without an fd (loopback) are polled at least every period
    if (poll(fds.data(), n, n > 1 || bus.enabled ? 50 : 1) < 0 && errno != EINTR) break;
    if (!bus.enabled) poll_answering(MonotonicNs());  // answer SYNCs with the latest state
    std::uint64_t fired = 0;
    if (read(tfd, &fired, sizeof fired) != static_cast<ssize_t>(sizeof fired) || fired == 0) continue;
    // the periods due by now: a late wake catches up (at most kMaxCatchUp steps at once),
    // counted as overruns; the SYNCs that arrive meanwhile are answered between the steps, with
    // the latest state
    const std::int64_t woke = MonotonicNs();
    const auto due = static_cast<std::uint64_t>(std::max<std::int64_t>(woke - due_ns, 0) / period_ns) + 1;
    counters_.overruns += due - 1;
    const std::uint64_t steps =
        std::min<std::uint64_t>({due, kMaxCatchUp, end_steps - robot_.counters().steps});
    for (std::uint64_t i = 0; i < steps; ++i) {
      const std::int64_t begin = MonotonicNs();
      step_lateness_.Add(begin - due_ns);
      if (begin - due_ns > period_ns) ++counters_.late_steps;
      const std::int64_t sync = robot_.last_sync_ns();
      if (lock.Active(sync, begin)) sync_phase_error_.Add(std::abs(lock.Error(begin, sync)));
      robot_.Step();
      const std::int64_t end = MonotonicNs();
      step_time_.Add(end - begin);
      if (!bus.enabled) poll_answering(end);
      due_ns += period_ns;
    }
    if (due > steps) {  // periods given up: the simulated time falls behind
      counters_.dropped_steps += due - steps;
      due_ns += static_cast<std::int64_t>(due - steps) * period_ns;
    }
    due_ns += lock.Correction(due_ns, robot_.last_sync_ns(), MonotonicNs());
    bus_.SetStepDue(due_ns);
    if (!arm(due_ns)) break;
  }
  bus_.Stop();
  close(tfd);
  return robot_.counters().steps - start;
}

}  // namespace hyq::sim
