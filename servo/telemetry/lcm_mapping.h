// What the telemetry thread adds to a snapshot's messages before publishing them, and an event as
// its LCM message. The snapshot's messages are filled by the servo (telemetry_snapshot.h); their
// fields are listed in lcmtypes/telemetry_fields.h. Telemetry thread only.
#pragma once

#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "servo/telemetry/telemetry_config.h"
#include "servo/telemetry/telemetry_snapshot.h"

namespace hyq::servo {

/// Sets the message's utime (µs) and cycle from the snapshot's.
template <class M>
void Stamp(const TelemetrySnapshot& s, M* m) noexcept {
  m->utime = s.time_ns / 1000;
  m->cycle = static_cast<std::int64_t>(s.cycle);
}

/// The health message's telemetry counters.
void SetCounters(const TelemetryStats& counters, hyq_lcm::lcmt_hyq_health* m) noexcept;

/// The event's strings are assigned into the message's (reserved) strings.
void ToLcm(const SafetyEvent& e, hyq_lcm::lcmt_hyq_event* m);

}  // namespace hyq::servo
