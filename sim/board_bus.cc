#include "sim/board_bus.h"

#include <poll.h>
#include <time.h>

#include <cerrno>

#include "hal/clock.h"

namespace hyq::sim {

BoardBus::BoardBus(SimulatedRobot* robot) : robot_(*robot) {}

BoardBus::~BoardBus() { Stop(); }

void BoardBus::Start(const std::function<void()>& setup) {
  stop_.store(false, std::memory_order_relaxed);
  robot_.ConnectBoardBus(this);
  thread_ = std::thread([this, setup] { Run(setup); });
}

void BoardBus::Stop() noexcept {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
  robot_.ConnectBoardBus(nullptr);
}

void BoardBus::TakeNewestSetpoints(SetpointFrame* f) noexcept {
  SetpointFrame newer;
  while (setpoint_frames_.TryPop(&newer)) *f = newer;
}

void BoardBus::Run(const std::function<void()>& setup) noexcept {
  if (setup) setup();
  std::array<pollfd, hal::kMaxBuses> fds{};
  nfds_t n = 0;
  for (std::size_t b = 0; b < robot_.num_buses(); ++b)
    if (robot_.channel_poll_fd(b) >= 0) fds[n++] = {robot_.channel_poll_fd(b), POLLIN, 0};
  // at least every millisecond: the boards' own timers (the set-point watchdog, heartbeats) run
  // when nothing arrives, e.g. after the master died
  constexpr int kTimeoutMs = 1;
  std::uint64_t seen = 0;
  std::int64_t last = MonotonicNs();
  while (!stop_.load(std::memory_order_relaxed)) {
    if (n > 0) {
      if (poll(fds.data(), n, kTimeoutMs) < 0 && errno != EINTR) break;
    } else {
      const timespec ms{0, 1'000'000};
      nanosleep(&ms, nullptr);
    }
    const std::int64_t now = MonotonicNs();
    gap_.Add(now - last);
    // the newest sensor values the stepping thread handed over, the faults due (at their
    // simulated time), the answers. The boards are hardware: their clocks (heartbeats, the
    // set-point watchdog) are the wall clock, as the master's is. On the simulated time, a
    // stepping thread catching up after a stall of its core (up to kMaxCatchUp steps at once)
    // moved them 9 ms in 0.3 ms, and a board whose last set-point came just before tripped on a
    // master that had never been late
    SensorFrame f;
    bool fresh = false;
    while (sensor_frames_.TryPop(&f)) fresh = true;
    if (fresh) robot_.SetBoardSensors(f);
    robot_.ApplyFaults(1e-9 * static_cast<double>(robot_.published_time_ns()));
    robot_.Poll(MonotonicNs());
    (void)setpoint_frames_.TryPush(robot_.BoardSetpoints());  // full: the stepping thread is
                                                              // stalled; it takes the next one
    last = MonotonicNs();
    poll_time_.Add(last - now);
    // a SYNC answered while the step that was due is more than a period late: the answer is
    // the latest state there is, the physics stood still meanwhile
    const std::uint64_t new_syncs = robot_.NoteNewSyncs(now, &seen);
    if (new_syncs > 0 && now - step_due_ns_.load(std::memory_order_relaxed) > robot_.period_ns())
      stale_answers_ += new_syncs;
  }
}

}  // namespace hyq::sim
