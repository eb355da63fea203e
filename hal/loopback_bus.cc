#include "hal/loopback_bus.h"

#include <utility>

#include "hal/protocol.h"

namespace hyq::hal {

LoopbackEndpoint::LoopbackEndpoint(LoopbackBus* bus, std::string name, std::size_t depth)
    : bus_(bus), name_(std::move(name)), ring_(depth) {}

bool LoopbackEndpoint::fd_enabled() const noexcept { return bus_->fd_; }

bool LoopbackEndpoint::Push(const CanFrame& f) noexcept {
  if (count_ == ring_.size()) {
    ++counters_.rx_overflow;
    return false;
  }
  CanFrame& slot = ring_[(head_ + count_) % ring_.size()];
  slot = f;
  slot.timestamp_ns = bus_->time_ns_;
  ++count_;
  return true;
}

CanStatus LoopbackEndpoint::Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept {
  *sent = 0;
  if (bus_->bus_off_) return CanStatus::kBusOff;
  for (const CanFrame& f : frames) {
    const bool fd = f.is_fd();
    const bool bad_len = fd ? (f.len > kCanFdMaxData || !IsValidFdLength(f.len))
                            : f.len > kCanClassicMaxData;
    const bool bad_id = f.is_extended() ? f.id > 0x1FFFFFFFu : f.id > 0x7FFu;
    if ((fd && !bus_->fd_) || bad_len || bad_id) {
      ++counters_.bad_frames;
      return CanStatus::kBadFrame;
    }
    for (auto& ep : bus_->endpoints_)
      if (ep.get() != this) ep->Push(f);
    ++counters_.tx_frames;
    ++*sent;
  }
  return CanStatus::kOk;
}

CanStatus LoopbackEndpoint::Receive(std::span<CanFrame> out, std::size_t* received) noexcept {
  *received = 0;
  while (*received < out.size() && count_ > 0) {
    out[*received] = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
    --count_;
    ++*received;
    ++counters_.rx_frames;
  }
  return bus_->bus_off_ ? CanStatus::kBusOff : CanStatus::kOk;
}

LoopbackBus::LoopbackBus(std::string name, std::size_t endpoints, std::size_t queue_depth, bool fd)
    : name_(std::move(name)), fd_(fd) {
  endpoints_.reserve(endpoints);
  for (std::size_t i = 0; i < endpoints; ++i)
    endpoints_.push_back(std::unique_ptr<LoopbackEndpoint>(
        new LoopbackEndpoint(this, name_ + "." + std::to_string(i), queue_depth)));
}

void LoopbackBus::SetBusOff(bool off) noexcept {
  if (off && !bus_off_)
    for (auto& ep : endpoints_) ++ep->counters_.bus_off_events;
  bus_off_ = off;
  for (auto& ep : endpoints_)
    ep->counters_.bus_state = off ? BusState::kBusOff : BusState::kErrorActive;
}

}  // namespace hyq::hal
