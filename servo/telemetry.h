// Telemetry and the operator command channel over LCM (docs/telemetry.md).
//
// The servo thread hands one TelemetrySnapshot per cycle and SafetyEvents as they happen to
// Push/PushEvent, and takes validated ServoCommands from PopCommand. Those three calls only touch
// lock-free SPSC rings (servo/spsc_ring.h): they never allocate, lock, block or throw, whatever
// the LCM side does. A telemetry thread (Start/Stop) empties the rings, fills preallocated LCM
// messages (lcmtypes/, package hyq_lcm), publishes them, and, when the command channel is
// enabled, receives, validates and rate-limits commands before queueing them for the servo.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "servo/telemetry_types.h"

namespace hyq::servo {

/// Default LCM URL: the standard multicast group, TTL 0 so that nothing leaves the host.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// What is published, where and how often. Publishing "every N" means snapshots whose cycle is a
/// multiple of N (0 = never); events are never decimated.
struct TelemetryConfig {
  bool enabled = true;                   // false: no LCM, no thread, Push* return false
  std::string lcm_url = kDefaultLcmUrl;
  std::string channel_prefix = "HYQ_";   // channels are prefix + JOINT_STATE, ... (see below)
  std::uint32_t joint_state_every = 1;   // lcmt_hyq_joint_state   on <prefix>JOINT_STATE
  std::uint32_t joint_torque_every = 1;  // lcmt_hyq_joint_torque  on <prefix>JOINT_TORQUE
  std::uint32_t base_state_every = 1;    // lcmt_hyq_base_state    on <prefix>BASE_STATE
  std::uint32_t contact_every = 1;       // lcmt_hyq_contact_state on <prefix>CONTACT
  std::uint32_t timing_every = 1;        // lcmt_hyq_servo_timing  on <prefix>TIMING
  std::uint32_t health_every = 100;      // lcmt_hyq_health        on <prefix>HEALTH (+ once at Stop)
  std::size_t snapshot_queue_capacity = 1024;  // power of two; 1 s of cycles at 1 kHz
  std::size_t event_queue_capacity = 256;      // power of two, separate from snapshots
  std::size_t command_queue_capacity = 16;     // power of two
  int idle_wait_ms = 1;                  // the thread's wait when there is nothing to do
};

/// The operator command channel (lcmt_hyq_command). Off unless enabled; when off, no
/// subscription exists at all.
struct CommandChannelConfig {
  bool enabled = false;
  std::string channel = "HYQ_COMMAND";
  double max_rate_hz = 10.0;             // accepted commands at most this often; faster ones are refused
  double mu_min = 0.0, mu_max = 2.0;     // accepted friction range (inclusive)
  double gain_scale_min = 0.1, gain_scale_max = 2.0;  // accepted kp/kd multipliers (inclusive)
  std::vector<std::string> allowed_controllers = {"pid", "noslip", "stage1", "two_stage"};
};

/// Counters since construction (each read atomically; together a snapshot, not a transaction).
struct TelemetryStats {
  std::uint64_t snapshots_pushed = 0, snapshots_dropped = 0, snapshots_published = 0;
  std::uint64_t events_pushed = 0, events_dropped = 0, events_published = 0;
  std::uint64_t messages_published = 0, publish_failures = 0;
  std::uint64_t commands_received = 0, commands_accepted = 0, commands_rejected = 0;
  std::uint64_t commands_dropped = 0;  // valid, but the command queue was full
};

/// "enable", "disable", "damp", "ack", "mu", "controller", "gains".
const char* ToString(ServoCommand::Kind k) noexcept;

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
