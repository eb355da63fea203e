// The telemetry module's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `telemetry.*` of config/hyq_servo.yaml) and the counters it
// keeps. The command channel's configuration is servo/command/command_config.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

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
  std::uint32_t friction_every = 1;      // lcmt_hyq_friction_estimate on <prefix>FRICTION
  std::uint32_t disturbance_every = 10;  // lcmt_hyq_disturbance_estimate on <prefix>DISTURBANCE
  std::uint32_t health_every = 100;      // lcmt_hyq_health        on <prefix>HEALTH (+ once at Stop)
  std::size_t snapshot_queue_capacity = 1024;  // power of two; 1 s of cycles at 1 kHz
  std::size_t event_queue_capacity = 256;      // power of two, separate from snapshots
  std::size_t command_queue_capacity = 16;     // power of two
  int idle_wait_ms = 1;                  // the thread's wait when there is nothing to do
};

/// Counters since construction (each read atomically; together a snapshot, not a transaction).
struct TelemetryStats {
  std::uint64_t snapshots_pushed = 0, snapshots_dropped = 0, snapshots_published = 0;
  std::uint64_t events_pushed = 0, events_dropped = 0, events_published = 0;
  std::uint64_t messages_published = 0, publish_failures = 0;
  std::uint64_t commands_received = 0, commands_accepted = 0, commands_rejected = 0;
  std::uint64_t commands_dropped = 0;  // valid, but the command queue was full
  std::uint64_t commands_unauthenticated = 0;  // unsigned, wrong key, altered, malformed envelope
  std::uint64_t commands_replayed = 0;         // authentic but stale, replayed or out of order
};

}  // namespace hyq::servo
