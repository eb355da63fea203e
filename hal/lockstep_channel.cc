#include "hal/lockstep_channel.h"

#include <poll.h>
#include <sched.h>

#include <algorithm>
#include <array>

#include "hal/clock.h"
#include "hal/hal.h"
#include "hal/protocol.h"

namespace hyq::hal {
LockstepChannel::LockstepChannel(std::unique_ptr<CanChannel> inner)
    : inner_(std::move(inner)) {
  buffer_.resize(kBufferFrames);
}

CanStatus LockstepChannel::Send(std::span<const CanFrame> frames,
                                     std::size_t* sent) noexcept {
  const CanStatus st = inner_->Send(frames, sent);
  for (std::size_t i = 0; i < *sent; ++i) {
    std::uint8_t counter = 0;
    if (DecodeSync(frames[i], &counter) != PdoStatus::kOk) continue;
    // a new SYNC: what is buffered answers earlier ones (the HAL still receives it)
    sync_counter_ = counter;
    tpdos_ = 0;
    tpdo_nodes_.reset();
  }
  return st;
}

CanStatus LockstepChannel::Receive(std::span<CanFrame> out,
                                        std::size_t* received) noexcept {
  std::size_t n = 0;
  while (n < out.size() && head_ < tail_) out[n++] = buffer_[head_++];
  if (head_ == tail_) {
    head_ = tail_ = 0;
    tpdos_ = 0;
    tpdo_nodes_.reset();
  }
  std::size_t more = 0;
  const CanStatus st = inner_->Receive(out.subspan(n), &more);
  *received = n + TakePlantClock(out.data() + n, more);
  return st;
}

std::size_t LockstepChannel::TakePlantClock(CanFrame* frames, std::size_t n) noexcept {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    PlantClock c;
    if (frames[i].id == cob::kPlantClock && DecodePlantClock(frames[i], &c) == PdoStatus::kOk) {
      plant_stalled_steps_ = std::max(plant_stalled_steps_, c.stalled_steps);
      continue;
    }
    if (kept != i) frames[kept] = frames[i];
    ++kept;
  }
  return kept;
}

int LockstepChannel::Pump() noexcept {
  if (tail_ < buffer_.size()) {
    std::size_t n = 0;
    (void)inner_->Receive(std::span(buffer_).subspan(tail_), &n);
    n = TakePlantClock(buffer_.data() + tail_, n);
    for (std::size_t i = tail_; i < tail_ + n; ++i) {
      const CanFrame& f = buffer_[i];
      if (f.is_extended() || f.is_error() || (f.id & 0x780u) != cob::kTpdo1) continue;
      const std::uint8_t answers = TpdoSyncCounter(f);
      if (sync_counter_ != 0 && answers != 0 && answers != sync_counter_) continue;  // late
      ++tpdos_;
      tpdo_nodes_.set(f.id & 0x7fu);
    }
    tail_ += n;
  }
  return tpdos_;
}

bool SpinForFrames(std::span<CanChannel* const> channels, std::int64_t budget_ns) noexcept {
  const auto pending = [&] {
    for (const CanChannel* c : channels)
      if (c->tells_pending() && c->frames_pending()) return true;
    return false;
  };
  for (CanChannel* c : channels) c->SetWaiterSpinning(true);
  const std::int64_t end = MonotonicNs() + budget_ns;
  bool found = false;
  do {
    found = pending();
    if (!found) sched_yield();
  } while (!found && MonotonicNs() < end);
  for (CanChannel* c : channels) c->SetWaiterSpinning(false);
  return found || pending();  // frames a writer did not ring for while we spun
}

bool WaitForLockstepInputs(const Hal& hal, std::span<LockstepChannel* const> channels,
                           std::int64_t timeout_ns, std::int64_t idle_ns) noexcept {
  int expected = 0;
  for (std::size_t b = 0; b < hal.num_buses(); ++b)
    for (const auto& d : hal.bus(b).devices()) expected += d.expect_inputs ? 1 : 0;
  const bool per_device = channels.size() == hal.num_buses();
  const auto answered = [&] {
    int got = 0;
    for (std::size_t b = 0; b < hal.num_buses(); ++b)
      for (const auto& d : hal.bus(b).devices())
        got += d.expect_inputs && channels[b]->has_tpdo_from(d.node) ? 1 : 0;
    return got;
  };
  std::array<pollfd, kMaxBuses> fds{};
  std::size_t nfds = 0;
  for (LockstepChannel* c : channels)
    if (c->poll_fd() >= 0 && nfds < fds.size()) fds[nfds++] = {c->poll_fd(), POLLIN, 0};
  std::array<CanChannel*, kMaxBuses> plain_channels{};
  std::size_t nplain = 0;
  bool spin = false;
  for (LockstepChannel* c : channels)
    if (nplain < plain_channels.size()) {
      plain_channels[nplain++] = c;
      spin = spin || c->tells_pending();
    }
  const std::span<CanChannel* const> plain(plain_channels.data(), nplain);
  const std::int64_t end =
      MonotonicNs() + (expected == 0 ? std::min(timeout_ns, idle_ns) : timeout_ns);
  for (;;) {
    int got = 0;
    for (LockstepChannel* c : channels) got += c->Pump();
    if (per_device) got = answered();
    if (expected > 0 && got >= expected) return true;
    const std::int64_t left = end - MonotonicNs();
    if (left <= 0) return expected == 0;
    if (spin && SpinForFrames(plain, std::min(left, kLockstepSpinNs))) continue;
    const timespec ts{static_cast<time_t>(left / 1'000'000'000), static_cast<long>(left % 1'000'000'000)};
    (void)ppoll(fds.data(), nfds, &ts, nullptr);
  }
}

}  // namespace hyq::hal
