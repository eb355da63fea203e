// Telemetry and the operator command channel over LCM (docs/telemetry.md).
//
// The servo thread hands one TelemetrySnapshot per cycle and SafetyEvents as they happen to
// Push/PushEvent, and takes validated ServoCommands from PopCommand. Those three calls only touch
// lock-free SPSC rings (hal/spsc_ring.h): they never allocate, lock, block or throw, whatever the
// LCM side does. A snapshot is made of the LCM messages themselves (telemetry_snapshot.h). A
// telemetry thread (Start/Stop) empties the rings, stamps the messages (servo/telemetry/
// lcm_mapping.h) and publishes them, and, when the command channel is enabled, receives commands
// and has them authenticated (servo/command/command_auth.h), decoded, validated and rate-limited
// (servo/command/command_channel.h) before queueing them for the servo.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "servo/command/command_config.h"
#include "servo/telemetry/telemetry_config.h"
#include "servo/telemetry/telemetry_snapshot.h"

namespace hyq::servo {

class Telemetry : public TelemetrySink {
 public:
  /// Replaces lcm publish for tests (e.g. one that blocks, to stall the publisher). Returns false
  /// on failure (counted as publish_failures). Called only on the telemetry thread.
  using PublishFn =
      std::function<bool(const std::string& channel, const void* data, std::size_t size)>;

  /// Creates the LCM instance, checks it is good, subscribes to the command channel when enabled
  /// and allocates the rings and messages.
  /// @throws std::runtime_error naming the URL when LCM cannot be created, std::invalid_argument
  ///         for a bad configuration (capacities not powers of two, empty ranges, unknown
  ///         controller names, non-positive rate).
  Telemetry(const TelemetryConfig& config, const CommandChannelConfig& commands = {},
            PublishFn publish = nullptr);
  ~Telemetry() override;  // Stop()
  Telemetry(const Telemetry&) = delete;
  Telemetry& operator=(const Telemetry&) = delete;

  /// Starts the telemetry thread (no-op when disabled or already running).
  void Start();
  /// Stops the thread after it has published everything still queued and a final health
  /// message; joins it. Idempotent.
  void Stop();

  // ---- servo thread: wait-free, noexcept, no allocation ----
  /// Queues one cycle's snapshot; false (and counted as dropped) when the queue is full.
  bool Push(const TelemetrySnapshot& snapshot) noexcept override;
  /// Queues an event on its own queue; false (and counted as dropped) when that is full.
  bool PushEvent(const SafetyEvent& event) noexcept override;
  /// Takes the oldest validated command; false when there is none.
  bool PopCommand(ServoCommand* command) noexcept override;

  // ---- any thread ----
  TelemetryStats stats() const noexcept;
  /// The full channel name of a suffix ("JOINT_STATE" -> "HYQ_JOINT_STATE").
  std::string channel(const char* suffix) const { return config_.channel_prefix + suffix; }
  /// True when the command channel subscription exists.
  bool command_subscribed() const noexcept;
  const TelemetryConfig& config() const noexcept { return config_; }

 private:
  struct Impl;
  TelemetryConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hyq::servo
