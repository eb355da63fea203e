// The HAL master and the device emulator talking over four UDP-multicast virtual CAN buses in
// one process (the emulator polls in its own thread), for the HAL-over-drivers test and the
// SYNC → inputs round-trip benchmark. Run inside a private network namespace (in_netns.sh).
#pragma once

#include <poll.h>
#include <time.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/protocol.h"

namespace hyq::testing {

inline std::int64_t MonotonicNs() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

/// Buffers received frames so a test can see that every TPDO answering the last SYNC has
/// arrived before the HAL's Read takes them (Read gets exactly the same frames, in order).
class PeekingChannel : public hal::CanChannel {
 public:
  explicit PeekingChannel(std::unique_ptr<hal::CanChannel> inner) : inner_(std::move(inner)) {
    buffer_.resize(4096);
  }
  hal::CanStatus Send(std::span<const hal::CanFrame> f, std::size_t* sent) noexcept override {
    return inner_->Send(f, sent);
  }
  hal::CanStatus Receive(std::span<hal::CanFrame> out, std::size_t* received) noexcept override {
    std::size_t n = 0;
    while (n < out.size() && head_ < tail_) out[n++] = buffer_[head_++];
    if (head_ == tail_) head_ = tail_ = tpdos_ = 0;
    std::size_t more = 0;
    const auto st = inner_->Receive(out.subspan(n), &more);
    *received = n + more;
    return st;
  }
  /// Moves pending frames into the buffer; returns the TPDOs buffered so far.
  int Pump() noexcept {
    std::size_t n = 0;
    if (tail_ < buffer_.size()) {
      (void)inner_->Receive(std::span(buffer_).subspan(tail_), &n);
      for (std::size_t i = tail_; i < tail_ + n; ++i)
        if (!buffer_[i].is_extended() && (buffer_[i].id & 0x780u) == hal::cob::kTpdo1) ++tpdos_;
      tail_ += n;
    }
    return tpdos_;
  }
  /// Frames buffered by Pump and not yet received.
  std::size_t buffered() const noexcept { return tail_ - head_; }
  const hal::CanCounters& counters() const noexcept override { return inner_->counters(); }
  bool fd_enabled() const noexcept override { return inner_->fd_enabled(); }
  std::string_view name() const noexcept override { return inner_->name(); }
  int poll_fd() const noexcept override { return inner_->poll_fd(); }

 private:
  std::unique_ptr<hal::CanChannel> inner_;
  std::vector<hal::CanFrame> buffer_;
  std::size_t head_ = 0, tail_ = 0;
  int tpdos_ = 0;
};

struct VirtualRig {
  explicit VirtualRig(int first_port) : cfg(config::LoadHalConfig(HYQ_HAL_CONFIG)) {
    std::vector<hal::CanChannel*> masters, devices;
    for (std::size_t b = 0; b < cfg.buses.size(); ++b) {
      const std::string spec = "udp::" + std::to_string(first_port + static_cast<int>(b));
      master.push_back(std::make_unique<PeekingChannel>(drivers::OpenChannel(spec)));
      device.push_back(drivers::OpenChannel(spec));
      masters.push_back(master.back().get());
      devices.push_back(device.back().get());
      device_fds.push_back({device.back()->poll_fd(), POLLIN, 0});
      master_fds.push_back({master.back()->poll_fd(), POLLIN, 0});
    }
    hal = std::make_unique<hal::Hal>(cfg, masters);
    emulator = std::make_unique<hal::Emulator>(cfg, devices);
    thread = std::thread([this] {
      while (!stop) {
        (void)poll(device_fds.data(), device_fds.size(), 1);
        emulator->Poll(MonotonicNs());
      }
    });
  }
  ~VirtualRig() {
    stop = true;
    thread.join();
  }
  /// Brings every device to OP (throws with the HAL's report if one does not come up). Each
  /// cycle waits (up to 5 ms) for the devices that answer SYNC to answer before the next Read,
  /// so a loaded machine slows the bring-up down instead of failing it.
  void BringUp() {
    std::int64_t now = MonotonicNs();
    hal::RunBringUp(*hal, hal::DeviceState::kOp, now, [&] {
      (void)WaitForInputs(13, 5'000'000);
      const std::int64_t next = now + 1'000'000;  // 1 kHz when the machine keeps up
      timespec t{next / 1'000'000'000, next % 1'000'000'000};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
      now = MonotonicNs();
      return now;
    });
    // bring-up ends with a Write: take that cycle's inputs so the next Write starts clean
    (void)WaitForInputs(13, 20'000'000);
    (void)hal->Read(MonotonicNs());
  }
  /// Waits (poll) until every master channel holds its bus's TPDOs for the last SYNC, at most
  /// timeout_ns; returns whether they all arrived.
  bool WaitForInputs(int expected, std::int64_t timeout_ns) {
    const std::int64_t end = MonotonicNs() + timeout_ns;
    for (;;) {
      int got = 0;
      for (auto& m : master) got += m->Pump();
      if (got >= expected) return true;
      if (MonotonicNs() >= end) return false;
      (void)poll(master_fds.data(), master_fds.size(), 0);
    }
  }

  hal::HalConfig cfg;
  std::vector<std::unique_ptr<PeekingChannel>> master;
  std::vector<std::unique_ptr<hal::CanChannel>> device;
  std::vector<pollfd> device_fds, master_fds;
  std::unique_ptr<hal::Hal> hal;
  std::unique_ptr<hal::Emulator> emulator;
  std::atomic<bool> stop{false};
  std::thread thread;
};

}  // namespace hyq::testing
