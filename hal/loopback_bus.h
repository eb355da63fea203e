// An in-process CAN bus for tests and the emulator: N endpoints, each a CanChannel; a frame one
// endpoint sends is received by every other endpoint (not by the sender, as on a real bus with
// own-echo off). Every endpoint's receive queue has a fixed depth chosen at construction; a full
// queue drops the frame and counts rx_overflow at that endpoint.
//
// Single-threaded: all endpoints must be used from one thread (the tests' and the benchmark's
// use). Send and Receive never allocate.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hal/can_channel.h"

namespace hyq::hal {

class LoopbackBus;

class LoopbackEndpoint final : public CanChannel {
 public:
  CanStatus Send(std::span<const CanFrame> frames, std::size_t* sent) noexcept override;
  CanStatus Receive(std::span<CanFrame> out, std::size_t* received) noexcept override;
  const CanCounters& counters() const noexcept override { return counters_; }
  bool fd_enabled() const noexcept override;
  std::string_view name() const noexcept override { return name_; }

  /// Frames waiting in this endpoint's receive queue.
  std::size_t pending() const noexcept { return count_; }

 private:
  friend class LoopbackBus;
  LoopbackEndpoint(LoopbackBus* bus, std::string name, std::size_t depth);
  bool Push(const CanFrame& f) noexcept;

  LoopbackBus* bus_;
  std::string name_;
  std::vector<CanFrame> ring_;
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  CanCounters counters_;
};

class LoopbackBus {
 public:
  /// `endpoints` channels named "<name>.0", "<name>.1", ...; `fd` lets them carry FD frames.
  LoopbackBus(std::string name, std::size_t endpoints, std::size_t queue_depth = 256,
              bool fd = true);
  LoopbackBus(const LoopbackBus&) = delete;
  LoopbackBus& operator=(const LoopbackBus&) = delete;

  LoopbackEndpoint& endpoint(std::size_t i) { return *endpoints_.at(i); }
  std::size_t size() const noexcept { return endpoints_.size(); }
  bool fd() const noexcept { return fd_; }

  /// Simulates the controller going bus-off (true) and recovering (false): while bus-off every
  /// Send returns kBusOff and queues nothing, and each endpoint reports BusState::kBusOff.
  void SetBusOff(bool off) noexcept;
  bool bus_off() const noexcept { return bus_off_; }

  /// The receive timestamp stamped on delivered frames (tests advance it).
  void set_time_ns(std::int64_t t) noexcept { time_ns_ = t; }

 private:
  friend class LoopbackEndpoint;
  std::string name_;
  bool fd_;
  bool bus_off_ = false;
  std::int64_t time_ns_ = 0;
  std::vector<std::unique_ptr<LoopbackEndpoint>> endpoints_;
};

}  // namespace hyq::hal
