// The fields of each hyq_lcm message, listed once: name, unit and element labels, in the order of
// lcmtypes/*.lcm. Every text form of the telemetry is derived from these lists: hyq-lcm-export's
// CSV columns (tools/hyq-lcm-export/csv_rows.h) and hyq-viewer's JSON (tools/hyq-viewer/
// telemetry_json.h). Adding a field to a message is one line in its .lcm file, one line here,
// and the line in the servo that sets its value (servo/runtime/servo_loop.cc, FillSnapshot).
//
// Why a visitor over the generated types, and not over the servo's own snapshot struct: the LCM
// messages are what every consumer sees (the daemon's and hyq-sim's publications, lcm-spy,
// logs), and their generated C++ types are plain aggregates of scalars and fixed arrays. So the
// servo's snapshot is made of the messages themselves (servo/telemetry/telemetry_snapshot.h) and
// there is no mapping left to write; the tools need only hyq::lcmtypes and this header, not the
// servo.
//
// The visitor, in the style of Drake's `template <typename Archive> void Serialize(Archive* a)`:
// for each message type M, `template <class A> void Serialize(A* a, M* m)` calls one of
//   a->Visit(name, unit, &m->scalar)                      a number, a string, or (unit "bool") an
//                                                         LCM boolean, held as int8_t
//   a->Visit(name, unit, &m->array, labels)               a fixed array, one label per element
//   a->Visit(name, unit, &m->array2, labels, labels2)     a fixed 2-D array (foot x axis)
//   a->Visit(name, unit, &m->vector, labels)              a variable array of at most labels
//   a->Visit(name, unit, &m->bytes)                       a fixed byte array, shown as one value
//   a->Visit(name, &m->structs, labels)                   a fixed array of messages, each label
//                                                         naming a whole element ("bus0")
// per field. Archives find Serialize by argument-dependent lookup, so a message type of another
// namespace (a test's) takes part with its own Serialize beside it. Writers take the message by
// pointer like readers would; they only read it.
#pragma once

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_bus_health.hpp"
#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_disturbance_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_friction_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
#include "hyq_lcm/lcmt_hyq_signed_command.hpp"
#include "hyq_lcm/lcmt_hyq_sim_truth.hpp"

namespace hyq_lcm {

/// Element labels: joints (legs lf, rf, lh, rh x haa, hfe, kfe), feet, axes, quaternion
/// components, buses and devices.
inline constexpr const char* kJointLabels[] = {"lf_haa", "lf_hfe", "lf_kfe", "rf_haa",
                                               "rf_hfe", "rf_kfe", "lh_haa", "lh_hfe",
                                               "lh_kfe", "rh_haa", "rh_hfe", "rh_kfe"};
inline constexpr const char* kFootLabels[] = {"lf", "rf", "lh", "rh"};
inline constexpr const char* kXyzLabels[] = {"x", "y", "z"};
inline constexpr const char* kWxyzLabels[] = {"w", "x", "y", "z"};
inline constexpr const char* kBusLabels[] = {"bus0", "bus1", "bus2", "bus3",
                                             "bus4", "bus5", "bus6", "bus7"};
inline constexpr const char* kDeviceLabels[] = {"0", "1", "2",  "3",  "4",  "5",  "6",  "7",
                                                "8", "9", "10", "11", "12", "13", "14", "15"};

template <class A>
void Serialize(A* a, lcmt_hyq_joint_state* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("mode", "enum", &m->mode);
  a->Visit("reference_time_s", "s", &m->reference_time_s);
  a->Visit("q_rad", "rad", &m->q_rad, kJointLabels);
  a->Visit("qd_rad_s", "rad/s", &m->qd_rad_s, kJointLabels);
  a->Visit("tau_measured_Nm", "N.m", &m->tau_measured_Nm, kJointLabels);
  a->Visit("q_ref_rad", "rad", &m->q_ref_rad, kJointLabels);
  a->Visit("qd_ref_rad_s", "rad/s", &m->qd_ref_rad_s, kJointLabels);
  a->Visit("input_status", "enum", &m->input_status, kJointLabels);
  a->Visit("tracking_error_rad", "rad", &m->tracking_error_rad);
}

template <class A>
void Serialize(A* a, lcmt_hyq_joint_torque* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("mode", "enum", &m->mode);
  a->Visit("controller", "enum", &m->controller);
  a->Visit("tau_command_Nm", "N.m", &m->tau_command_Nm, kJointLabels);
}

template <class A>
void Serialize(A* a, lcmt_hyq_base_state* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("position_m", "m", &m->position_m, kXyzLabels);
  a->Visit("orientation_wxyz", "1", &m->orientation_wxyz, kWxyzLabels);
  a->Visit("velocity_m_s", "m/s", &m->velocity_m_s, kXyzLabels);
  a->Visit("angular_velocity_rad_s", "rad/s", &m->angular_velocity_rad_s, kXyzLabels);
  a->Visit("position_std_m", "m", &m->position_std_m, kXyzLabels);
  a->Visit("velocity_std_m_s", "m/s", &m->velocity_std_m_s, kXyzLabels);
  a->Visit("orientation_std_rad", "rad", &m->orientation_std_rad, kXyzLabels);
  a->Visit("gyro_bias_rad_s", "rad/s", &m->gyro_bias_rad_s, kXyzLabels);
  a->Visit("accel_bias_m_s2", "m/s2", &m->accel_bias_m_s2, kXyzLabels);
  a->Visit("still", "bool", &m->still);
}

template <class A>
void Serialize(A* a, lcmt_hyq_contact_state* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("controller", "enum", &m->controller);
  a->Visit("stance_reference", "bool", &m->stance_reference, kFootLabels);
  a->Visit("stance_estimated", "bool", &m->stance_estimated, kFootLabels);
  a->Visit("contact_probability", "1", &m->contact_probability, kFootLabels);
  a->Visit("foot_used", "bool", &m->foot_used, kFootLabels);
  a->Visit("foot_rejected", "bool", &m->foot_rejected, kFootLabels);
  a->Visit("foot_mahalanobis_sq", "1", &m->foot_mahalanobis_sq, kFootLabels);
  a->Visit("foot_rejections", "count", &m->foot_rejections, kFootLabels);
  a->Visit("mu", "1", &m->mu, kFootLabels);
  a->Visit("contact_force_N", "N", &m->contact_force_N, kFootLabels, kXyzLabels);
  a->Visit("ground_force_N", "N", &m->ground_force_N, kFootLabels, kXyzLabels);
  a->Visit("landed_probability", "1", &m->landed_probability, kFootLabels);
  a->Visit("gait_phase", "enum", &m->gait_phase, kFootLabels);
  a->Visit("stage1_status", "enum", &m->stage1_status);
  a->Visit("stage2_status", "enum", &m->stage2_status);
  a->Visit("fallback", "enum", &m->fallback);
  a->Visit("stage1_iterations", "count", &m->stage1_iterations);
  a->Visit("stage2_iterations", "count", &m->stage2_iterations);
  a->Visit("stage1_solve_us", "us", &m->stage1_solve_us);
  a->Visit("stage2_solve_us", "us", &m->stage2_solve_us);
}

template <class A>
void Serialize(A* a, lcmt_hyq_disturbance_estimate* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("enabled", "bool", &m->enabled);
  a->Visit("held", "bool", &m->held);
  a->Visit("force_N", "N", &m->force_N, kXyzLabels);
  a->Visit("torque_Nm", "N*m", &m->torque_Nm, kXyzLabels);
  a->Visit("payload_kg", "kg", &m->payload_kg);
}

template <class A>
void Serialize(A* a, lcmt_hyq_friction_estimate* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("enabled", "bool", &m->enabled);
  a->Visit("mu_estimate", "1", &m->mu_estimate, kFootLabels);
  a->Visit("mu_control", "1", &m->mu_control, kFootLabels);
  a->Visit("mu_upper", "1", &m->mu_upper, kFootLabels);
  a->Visit("confidence", "1", &m->confidence, kFootLabels);
  a->Visit("force_ratio", "1", &m->force_ratio, kFootLabels);
  a->Visit("slip_speed_m_s", "m/s", &m->slip_speed_m_s, kFootLabels);
  a->Visit("force_N", "N", &m->force_N, kFootLabels, kXyzLabels);
  a->Visit("loaded", "bool", &m->loaded, kFootLabels);
  a->Visit("slipping", "bool", &m->slipping, kFootLabels);
  a->Visit("slips", "count", &m->slips, kFootLabels);
  a->Visit("footfalls", "count", &m->footfalls, kFootLabels);
  a->Visit("evidence_held", "bool", &m->evidence_held, kFootLabels);
  a->Visit("held_cycles", "count", &m->held_cycles, kFootLabels);
}

template <class A>
void Serialize(A* a, lcmt_hyq_servo_timing* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("wakeup_latency_ns", "ns", &m->wakeup_latency_ns);
  a->Visit("read_ns", "ns", &m->read_ns);
  a->Visit("estimate_ns", "ns", &m->estimate_ns);
  a->Visit("reference_ns", "ns", &m->reference_ns);
  a->Visit("control_ns", "ns", &m->control_ns);
  a->Visit("safety_ns", "ns", &m->safety_ns);
  a->Visit("write_ns", "ns", &m->write_ns);
  a->Visit("total_ns", "ns", &m->total_ns);
  a->Visit("deadline_misses", "count", &m->deadline_misses);
  a->Visit("consecutive_misses", "count", &m->consecutive_misses);
  a->Visit("skipped_cycles", "count", &m->skipped_cycles);
}

template <class A>
void Serialize(A* a, lcmt_hyq_bus_health* m) {
  a->Visit("rx_frames", "count", &m->rx_frames);
  a->Visit("tx_frames", "count", &m->tx_frames);
  a->Visit("wkc_faults", "count", &m->wkc_faults);
  a->Visit("missing", "count", &m->missing);
  a->Visit("malformed", "count", &m->malformed);
  a->Visit("error_frames", "count", &m->error_frames);
  a->Visit("emcy", "count", &m->emcy);
  a->Visit("bus_off", "count", &m->bus_off);
  a->Visit("tx_failed", "count", &m->tx_failed);
  a->Visit("driver_dropped", "count", &m->driver_dropped);
  a->Visit("wkc_expected", "count", &m->wkc_expected);
  a->Visit("wkc_received", "count", &m->wkc_received);
}

template <class A>
void Serialize(A* a, lcmt_hyq_health* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("mode", "enum", &m->mode);
  a->Visit("hal_read_status", "enum", &m->hal_read_status);
  a->Visit("hal_write_status", "enum", &m->hal_write_status);
  a->Visit("num_buses", "count", &m->num_buses);
  a->Visit("buses", &m->buses, kBusLabels);
  a->Visit("num_devices", "count", &m->num_devices);
  a->Visit("device_state", "enum", &m->device_state, kDeviceLabels);
  a->Visit("held_inputs", "count", &m->held_inputs, kDeviceLabels);
  a->Visit("max_held_in_row", "count", &m->max_held_in_row, kDeviceLabels);
  a->Visit("max_held_cycles", "count", &m->max_held_cycles);
  a->Visit("safety_events", "count", &m->safety_events);
  a->Visit("snapshots_dropped", "count", &m->snapshots_dropped);
  a->Visit("events_dropped", "count", &m->events_dropped);
  a->Visit("snapshots_published", "count", &m->snapshots_published);
  a->Visit("publish_failures", "count", &m->publish_failures);
  a->Visit("commands_received", "count", &m->commands_received);
  a->Visit("commands_accepted", "count", &m->commands_accepted);
  a->Visit("commands_rejected", "count", &m->commands_rejected);
  a->Visit("commands_dropped", "count", &m->commands_dropped);
  a->Visit("commands_unauthenticated", "count", &m->commands_unauthenticated);
  a->Visit("commands_replayed", "count", &m->commands_replayed);
}

template <class A>
void Serialize(A* a, lcmt_hyq_event* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("cycle", "count", &m->cycle);
  a->Visit("from_mode", "enum", &m->from_mode);
  a->Visit("to_mode", "enum", &m->to_mode);
  a->Visit("from_name", "text", &m->from_name);
  a->Visit("to_name", "text", &m->to_name);
  a->Visit("reason_code", "enum", &m->reason_code);
  a->Visit("reason", "text", &m->reason);
  a->Visit("joint", "index", &m->joint);
  a->Visit("bus", "index", &m->bus);
  a->Visit("detail", "text", &m->detail);
  a->Visit("stop_code", "enum", &m->stop_code);
  a->Visit("stop", "text", &m->stop);
}

template <class A>
void Serialize(A* a, lcmt_hyq_sim_truth* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("step", "count", &m->step);
  a->Visit("sim_time_s", "s", &m->sim_time_s);
  a->Visit("position_m", "m", &m->position_m, kXyzLabels);
  a->Visit("orientation_wxyz", "1", &m->orientation_wxyz, kWxyzLabels);
  a->Visit("velocity_m_s", "m/s", &m->velocity_m_s, kXyzLabels);
  a->Visit("angular_velocity_rad_s", "rad/s", &m->angular_velocity_rad_s, kXyzLabels);
  a->Visit("q_rad", "rad", &m->q_rad, kJointLabels);
  a->Visit("contact_force_N", "N", &m->contact_force_N, kFootLabels, kXyzLabels);
  a->Visit("touching", "bool", &m->touching, kFootLabels);
  a->Visit("mu", "1", &m->mu, kFootLabels);
  a->Visit("holding", "bool", &m->holding);
}

// The velocity's components have different units, so they are listed one by one.
template <class A>
void Serialize(A* a, lcmt_hyq_command* m) {
  a->Visit("utime", "us", &m->utime);
  a->Visit("sequence", "count", &m->sequence);
  a->Visit("kind", "enum", &m->kind);
  a->Visit("num_feet", "count", &m->num_feet);
  a->Visit("mu", "1", &m->mu, kFootLabels);
  a->Visit("controller", "text", &m->controller);
  a->Visit("kp_scale", "1", &m->kp_scale);
  a->Visit("kd_scale", "1", &m->kd_scale);
  a->Visit("velocity.vx", "m/s", &m->velocity[0]);
  a->Visit("velocity.vy", "m/s", &m->velocity[1]);
  a->Visit("velocity.wz", "rad/s", &m->velocity[2]);
}

// The envelope only: the command inside stays opaque until the servo has checked its MAC.
template <class A>
void Serialize(A* a, lcmt_hyq_signed_command* m) {
  a->Visit("sender", "text", &m->sender);
  a->Visit("command_size", "bytes", &m->command_size);
  a->Visit("mac", "hex", &m->mac);
}

}  // namespace hyq_lcm
