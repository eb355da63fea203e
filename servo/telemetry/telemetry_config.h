// The telemetry module's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `telemetry.*` and `commands.*` of config/hyq_servo.yaml)
// and the counters it keeps.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

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

/// The operator command channel (lcmt_hyq_signed_command carrying an lcmt_hyq_command; see
/// docs/security.md). Off unless enabled; when off, no subscription exists at all.
struct CommandChannelConfig {
  bool enabled = false;
  std::string channel = "HYQ_COMMAND";
  std::string key_file = "/etc/hyq/command.key";  // the robot's key (hyq-command --generate-key)
  double max_age_ms = 1000.0;            // a command's utime within this of the robot's clock
  std::size_t max_senders = 16;          // distinct senders whose last sequence is remembered
  /// The interface the command group must be joined on (the routing table decides it for liblcm);
  /// a different one is a start-up error. Empty: not checked.
  std::string interface = "lo";
  double max_rate_hz = 10.0;             // accepted commands at most this often; faster ones are refused
  double mu_min = 0.0, mu_max = 2.0;     // accepted friction range (inclusive)
  double gain_scale_min = 0.1, gain_scale_max = 2.0;  // accepted kp/kd multipliers (inclusive)
  /// accepted |vx| m/s, |vy| m/s, |wz| rad/s of a set-velocity command (inclusive)
  std::array<double, 3> max_velocity{0.4, 0.2, 0.5};
  std::vector<std::string> allowed_controllers = {"pid", "noslip", "stage1", "two_stage", "pd_gravity"};
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
