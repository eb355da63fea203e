// The telemetry module's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `telemetry.*` of config/hyq_servo.yaml) and the counters it
// keeps. The command channel's configuration is servo/command/command_config.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "hal/config_key.h"
#include "servo/command/command_config.h"
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
