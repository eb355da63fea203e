// The telemetry module's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `telemetry.*` and `commands.*` of config/hyq_servo.yaml)
// and the counters it keeps.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hal/config_key.h"
#include "servo/common/servo_types.h"
#include "servo/telemetry/lcm_url.h"

namespace hyq::servo {

/// Default LCM URL: the standard multicast group, TTL 0 so that nothing leaves the host.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// A queue capacity: a power of two (servo/telemetry/spsc_ring.h).
inline std::optional<hal::Violation> PowerOfTwo(const std::size_t& v) {
  if ((v & (v - 1)) != 0) return hal::Violation{"a power of two in [2, 1048576]"};
  return std::nullopt;
}

/// A bound in a message, without trailing zeros ("0.05").
inline std::string FormatBound(double x) {
  std::string s = std::to_string(x);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

/// A channel name LCM reads as it is: LCM subscribes by regular expression.
bool IsPlainChannelName(const std::string& name) noexcept;  // servo/telemetry/command_channel.cc

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

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled).Doc("false: no LCM, no telemetry thread"));
    a->Visit(hal::Key("lcm_url", &lcm_url)
                 .Check([](const std::string& url) -> std::optional<hal::Violation> {
                   // ParseLcmUrl says "<what>: expected ..., found ...": the part at fault
                   // follows the key, the expectation is the rest
                   try {
                     (void)ParseLcmUrl(url, "");
                   } catch (const std::invalid_argument& e) {
                     const std::string what = e.what();
                     const std::size_t at = what.find(": expected ");
                     const std::size_t found = what.rfind(", found ");
                     return hal::Violation{what.substr(at + 11, found - at - 11), -1, what.substr(0, at)};
                   }
                   return std::nullopt;
                 })
                 .Doc("udpm://GROUP:PORT?ttl=N, memq:// or file://PATH (ttl=0: never leaves the host)"));
    a->Visit(hal::Key("channel_prefix", &channel_prefix)
                 .Check([](const std::string& p) -> std::optional<hal::Violation> {
                   if (!IsPlainChannelName(p + "X")) return hal::Violation{"[A-Za-z0-9_]* (no regular expression)"};
                   return std::nullopt;
                 })
                 .Doc("channels are this + JOINT_STATE, JOINT_TORQUE, BASE_STATE, ..."));
    // every N cycles (0 = never)
    a->Visit(hal::Key("joint_state_every", &joint_state_every).In(0, 100000)
                 .Doc("publish on the prefix + JOINT_STATE every N cycles (0: never)"));
    a->Visit(hal::Key("joint_torque_every", &joint_torque_every).In(0, 100000)
                 .Doc("... + JOINT_TORQUE"));
    a->Visit(hal::Key("base_state_every", &base_state_every).In(0, 100000)
                 .Doc("... + BASE_STATE"));
    a->Visit(hal::Key("contact_every", &contact_every).In(0, 100000)
                 .Doc("... + CONTACT"));
    a->Visit(hal::Key("friction_every", &friction_every).In(0, 100000)
                 .Doc("... + FRICTION"));
    a->Visit(hal::Key("disturbance_every", &disturbance_every).In(0, 100000)
                 .Doc("... + DISTURBANCE"));
    a->Visit(hal::Key("timing_every", &timing_every).In(0, 100000)
                 .Doc("... + TIMING"));
    a->Visit(hal::Key("health_every", &health_every).In(0, 100000)
                 .Doc("... + HEALTH (and once at the stop)"));
    a->Visit(hal::Key("snapshot_queue_capacity", &snapshot_queue_capacity).In(2, 1 << 20)
                 .Check(PowerOfTwo).Doc("cycles queued for the telemetry thread (a power of two)"));
    a->Visit(hal::Key("event_queue_capacity", &event_queue_capacity).In(2, 1 << 20)
                 .Check(PowerOfTwo).Doc("events queued, apart from the snapshots (a power of two)"));
    a->Visit(hal::Key("command_queue_capacity", &command_queue_capacity).In(2, 1 << 20)
                 .Check(PowerOfTwo).Doc("accepted commands queued for the servo thread (a power of two)"));
    a->Visit(hal::Key("idle_wait_ms", &idle_wait_ms).In(0, 1000).Unit("ms")
                 .Doc("the telemetry thread's wait when there is nothing to do"));
  }
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

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled).Doc("the LCM command channel exists only when enabled"));
    a->Visit(hal::Key("channel", &channel)
                 .Check([](const std::string& c) -> std::optional<hal::Violation> {
                   if (!IsPlainChannelName(c))
                     return hal::Violation{"a plain channel name [A-Za-z0-9_]+ (LCM reads a pattern as a "
                                           "regular expression)"};
                   return std::nullopt;
                 })
                 .Doc("the channel commands arrive on (not one the telemetry publishes on)"));
    a->Visit(hal::Key("key_file", &key_file).Path()
                 .Doc("the robot's key, readable by its owner alone (docs/security.md)"));
    a->Visit(hal::Key("max_age_ms", &max_age_ms).In(1.0, 60000.0).Unit("ms")
                 .Doc("a command's time within this of the robot's clock"));
    a->Visit(hal::Key("max_senders", &max_senders).In(1, 1024)
                 .Doc("distinct senders whose last sequence number is remembered"));
    a->Visit(hal::Key("interface", &interface)
                 .Doc("the command group must route via this network interface"));
    a->Visit(hal::Key("max_rate_hz", &max_rate_hz).In(0.1, 1000.0).Unit("Hz")
                 .Doc("accepted commands at most this often"));
    a->Visit(hal::Key("mu_min", &mu_min).In(0.0, 10.0).Doc("accepted friction range: lowest"));
    a->Visit(hal::Key("mu_max", &mu_max).In(0.0, 10.0)
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v < mu_min) return hal::Violation{"mu_max >= mu_min (" + FormatBound(mu_min) + ")"};
                   return std::nullopt;
                 })
                 .Doc("accepted friction range: highest"));
    a->Visit(hal::Key("gain_scale_min", &gain_scale_min).In(1e-3, 100.0)
                 .Doc("accepted kp/kd multipliers: lowest"));
    a->Visit(hal::Key("gain_scale_max", &gain_scale_max).In(1e-3, 100.0)
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v < gain_scale_min)
                     return hal::Violation{"gain_scale_max >= gain_scale_min (" + FormatBound(gain_scale_min) + ")"};
                   return std::nullopt;
                 })
                 .Doc("accepted kp/kd multipliers: highest"));
    a->Visit(hal::Key("max_velocity", &max_velocity).In(0.0, 1.0).MaxEach({1.0, 0.5, 1.5})
                 .Elements("[vx, vy, wz]").Unit("m/s, m/s, rad/s")
                 .Doc("set-velocity commands accepted up to |vx|, |vy|, |wz|"));
    a->Visit(hal::Key("allowed_controllers", &allowed_controllers)
                 .Check([](const std::vector<std::string>& names) -> std::optional<hal::Violation> {
                   for (std::size_t i = 0; i < names.size(); ++i)
                     if (!ParseControllerKind(names[i])) {
                       std::string expected = "one of";
                       for (const auto& c : ControllerKindChoices())
                         expected.append(expected == "one of" ? " " : ", ").append(c.name);
                       return hal::Violation{expected, static_cast<int>(i)};
                     }
                   return std::nullopt;
                 })
                 .Doc("the controllers a command may switch to"));
  }
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
