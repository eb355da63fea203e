#include "servo/telemetry/lcm_mapping.h"

#include <cstring>

namespace hyq::servo {

void SetCounters(const TelemetryStats& st, hyq_lcm::lcmt_hyq_health* m) noexcept {
  m->snapshots_dropped = static_cast<std::int64_t>(st.snapshots_dropped);
  m->events_dropped = static_cast<std::int64_t>(st.events_dropped);
  m->snapshots_published = static_cast<std::int64_t>(st.snapshots_published);
  m->publish_failures = static_cast<std::int64_t>(st.publish_failures);
  m->commands_received = static_cast<std::int64_t>(st.commands_received);
  m->commands_accepted = static_cast<std::int64_t>(st.commands_accepted);
  m->commands_rejected = static_cast<std::int64_t>(st.commands_rejected);
  m->commands_dropped = static_cast<std::int64_t>(st.commands_dropped);
  m->commands_unauthenticated = static_cast<std::int64_t>(st.commands_unauthenticated);
  m->commands_replayed = static_cast<std::int64_t>(st.commands_replayed);
}

void ToLcm(const SafetyEvent& e, hyq_lcm::lcmt_hyq_event* out) {
  hyq_lcm::lcmt_hyq_event& m = *out;
  m.utime = e.time_ns / 1000;
  m.cycle = static_cast<std::int64_t>(e.cycle);
  m.from_mode = static_cast<std::int8_t>(e.from);
  m.to_mode = static_cast<std::int8_t>(e.to);
  m.from_name = ToString(e.from);
  m.to_name = ToString(e.to);
  m.reason_code = static_cast<std::int16_t>(e.reason);
  m.reason = ToString(e.reason);
  m.joint = e.joint;
  m.bus = e.bus;
  m.detail.assign(e.detail.data(), strnlen(e.detail.data(), e.detail.size()));
  m.stop_code = static_cast<std::int8_t>(e.stop);
  m.stop = ToString(e.stop);
}

}  // namespace hyq::servo
