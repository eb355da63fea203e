// The telemetry's LCM messages (lcmtypes/, package hyq_lcm) filled from one cycle's snapshot or
// one event: the mapping, field by field, with nothing of the publishing (servo/telemetry/
// telemetry.h). Telemetry thread only; the snapshot's capacities and the messages' arrays are
// tied by static_assert in lcm_mapping.cc.
#pragma once

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_disturbance_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_friction_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
#include "servo/telemetry/telemetry_config.h"
#include "servo/telemetry/telemetry_snapshot.h"

namespace hyq::servo {

void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_joint_state* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_joint_torque* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_base_state* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_contact_state* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_friction_estimate* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_disturbance_estimate* m) noexcept;
void ToLcm(const TelemetrySnapshot& s, hyq_lcm::lcmt_hyq_servo_timing* m) noexcept;
/// The health message: the snapshot's bus and device health and the telemetry's own counters.
void ToLcm(const TelemetrySnapshot& s, const TelemetryStats& counters,
           hyq_lcm::lcmt_hyq_health* m) noexcept;
/// The event's strings are assigned into the message's (reserved) strings.
void ToLcm(const SafetyEvent& e, hyq_lcm::lcmt_hyq_event* m);

}  // namespace hyq::servo
