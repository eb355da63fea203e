#include "tools/hyq-lcm-export/csv_rows.h"

#include <array>
#include <climits>
#include <cstddef>
#include <cstdio>
#include <exception>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "hyq_lcm/lcmt_hyq_signed_command.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_disturbance_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_friction_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_health.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
#include "hyq_lcm/lcmt_hyq_sim_truth.hpp"

namespace hyq::lcm_export {
namespace {

constexpr const char* kJoints[] = {"lf_haa", "lf_hfe", "lf_kfe", "rf_haa", "rf_hfe", "rf_kfe",
                                   "lh_haa", "lh_hfe", "lh_kfe", "rh_haa", "rh_hfe", "rh_kfe"};
constexpr const char* kFeet[] = {"lf", "rf", "lh", "rh"};
constexpr const char* kXyz[] = {"x", "y", "z"};
constexpr const char* kWxyz[] = {"w", "x", "y", "z"};

// Writes either the header cells or one row's cells of a message, in the same order.
class Csv {
 public:
  Csv(bool header, std::string* line) : header_(header), line_(line) {}

  template <class T>
  void Field(const std::string& name, const char* unit, const T& value) {
    Sep();
    if (header_) {
      *line_ += name + " (" + unit + ")";
    } else {
      Value(value);
    }
  }
  template <class T, std::size_t N>
  void Array(const std::string& name, const char* unit, const T (&values)[N],
             const char* const (&labels)[N]) {
    for (std::size_t i = 0; i < N; ++i) Field(name + "." + labels[i], unit, values[i]);
  }

 private:
  void Sep() {
    if (!line_->empty()) *line_ += ',';
  }
  void Value(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.17g", v);
    *line_ += b;
  }
  void Value(std::int64_t v) { *line_ += std::to_string(v); }
  void Value(std::int32_t v) { *line_ += std::to_string(v); }
  void Value(std::int16_t v) { *line_ += std::to_string(v); }
  void Value(std::int8_t v) { *line_ += std::to_string(static_cast<int>(v)); }
  void Value(bool v) { *line_ += v ? '1' : '0'; }
  void Value(const std::string& s) {
    *line_ += '"';
    for (char c : s) {
      if (c == '"') *line_ += '"';
      *line_ += (c == '\n' || c == '\r') ? ' ' : c;
    }
    *line_ += '"';
  }

  bool header_;
  std::string* line_;
};

void Visit(const hyq_lcm::lcmt_hyq_joint_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("reference_time_s", "s", m.reference_time_s);
  c.Array("q_rad", "rad", m.q_rad, kJoints);
  c.Array("qd_rad_s", "rad/s", m.qd_rad_s, kJoints);
  c.Array("tau_measured_Nm", "N.m", m.tau_measured_Nm, kJoints);
  c.Array("q_ref_rad", "rad", m.q_ref_rad, kJoints);
  c.Array("qd_ref_rad_s", "rad/s", m.qd_ref_rad_s, kJoints);
  c.Array("input_status", "enum", m.input_status, kJoints);
  c.Field("tracking_error_rad", "rad", m.tracking_error_rad);
}
void Visit(const hyq_lcm::lcmt_hyq_joint_torque& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("controller", "enum", m.controller);
  c.Array("tau_command_Nm", "N.m", m.tau_command_Nm, kJoints);
}
void Visit(const hyq_lcm::lcmt_hyq_base_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Array("position_m", "m", m.position_m, kXyz);
  c.Array("orientation_wxyz", "1", m.orientation_wxyz, kWxyz);
  c.Array("velocity_m_s", "m/s", m.velocity_m_s, kXyz);
  c.Array("angular_velocity_rad_s", "rad/s", m.angular_velocity_rad_s, kXyz);
}
void Visit(const hyq_lcm::lcmt_hyq_contact_state& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("controller", "enum", m.controller);
  for (int f = 0; f < 4; ++f) c.Field(std::string("stance_reference.") + kFeet[f], "bool", m.stance_reference[f] != 0);
  for (int f = 0; f < 4; ++f) c.Field(std::string("stance_estimated.") + kFeet[f], "bool", m.stance_estimated[f] != 0);
  c.Array("mu", "1", m.mu, kFeet);
  for (int f = 0; f < 4; ++f)
    c.Array(std::string("contact_force_N.") + kFeet[f], "N", m.contact_force_N[f], kXyz);
  c.Field("stage1_status", "enum", m.stage1_status);
  c.Field("stage2_status", "enum", m.stage2_status);
  c.Field("fallback", "enum", m.fallback);
  c.Field("stage1_iterations", "count", m.stage1_iterations);
  c.Field("stage2_iterations", "count", m.stage2_iterations);
  c.Field("stage1_solve_us", "us", m.stage1_solve_us);
  c.Field("stage2_solve_us", "us", m.stage2_solve_us);
}
void Visit(const hyq_lcm::lcmt_hyq_disturbance_estimate& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("enabled", "bool", m.enabled != 0);
  c.Field("held", "bool", m.held != 0);
  c.Array("force_N", "N", m.force_N, kXyz);
  c.Array("torque_Nm", "N*m", m.torque_Nm, kXyz);
  c.Field("payload_kg", "kg", m.payload_kg);
}
void Visit(const hyq_lcm::lcmt_hyq_friction_estimate& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("enabled", "bool", m.enabled != 0);
  c.Array("mu_estimate", "1", m.mu_estimate, kFeet);
  c.Array("mu_control", "1", m.mu_control, kFeet);
  c.Array("mu_upper", "1", m.mu_upper, kFeet);
  c.Array("confidence", "1", m.confidence, kFeet);
  c.Array("force_ratio", "1", m.force_ratio, kFeet);
  c.Array("slip_speed_m_s", "m/s", m.slip_speed_m_s, kFeet);
  for (int f = 0; f < 4; ++f) c.Array(std::string("force_N.") + kFeet[f], "N", m.force_N[f], kXyz);
  for (int f = 0; f < 4; ++f) c.Field(std::string("loaded.") + kFeet[f], "bool", m.loaded[f] != 0);
  for (int f = 0; f < 4; ++f) c.Field(std::string("slipping.") + kFeet[f], "bool", m.slipping[f] != 0);
  c.Array("slips", "count", m.slips, kFeet);
  c.Array("footfalls", "count", m.footfalls, kFeet);
}
void Visit(const hyq_lcm::lcmt_hyq_sim_truth& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("step", "count", m.step);
  c.Field("sim_time_s", "s", m.sim_time_s);
  c.Array("position_m", "m", m.position_m, kXyz);
  c.Array("orientation_wxyz", "1", m.orientation_wxyz, kWxyz);
  c.Array("velocity_m_s", "m/s", m.velocity_m_s, kXyz);
  c.Array("angular_velocity_rad_s", "rad/s", m.angular_velocity_rad_s, kXyz);
  c.Array("q_rad", "rad", m.q_rad, kJoints);
  for (int f = 0; f < 4; ++f)
    c.Array(std::string("contact_force_N.") + kFeet[f], "N", m.contact_force_N[f], kXyz);
  for (int f = 0; f < 4; ++f) c.Field(std::string("touching.") + kFeet[f], "bool", m.touching[f] != 0);
  c.Array("mu", "1", m.mu, kFeet);
  c.Field("holding", "bool", m.holding != 0);
}
void Visit(const hyq_lcm::lcmt_hyq_servo_timing& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("wakeup_latency_ns", "ns", m.wakeup_latency_ns);
  c.Field("read_ns", "ns", m.read_ns);
  c.Field("estimate_ns", "ns", m.estimate_ns);
  c.Field("reference_ns", "ns", m.reference_ns);
  c.Field("control_ns", "ns", m.control_ns);
  c.Field("safety_ns", "ns", m.safety_ns);
  c.Field("write_ns", "ns", m.write_ns);
  c.Field("total_ns", "ns", m.total_ns);
  c.Field("deadline_misses", "count", m.deadline_misses);
  c.Field("consecutive_misses", "count", m.consecutive_misses);
  c.Field("skipped_cycles", "count", m.skipped_cycles);
}
void Visit(const hyq_lcm::lcmt_hyq_health& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("mode", "enum", m.mode);
  c.Field("hal_read_status", "enum", m.hal_read_status);
  c.Field("hal_write_status", "enum", m.hal_write_status);
  c.Field("num_buses", "count", m.num_buses);
  for (int b = 0; b < 8; ++b) {
    const auto& h = m.buses[b];
    const std::string p = "bus" + std::to_string(b) + ".";
    c.Field(p + "rx_frames", "count", h.rx_frames);
    c.Field(p + "tx_frames", "count", h.tx_frames);
    c.Field(p + "wkc_faults", "count", h.wkc_faults);
    c.Field(p + "missing", "count", h.missing);
    c.Field(p + "malformed", "count", h.malformed);
    c.Field(p + "error_frames", "count", h.error_frames);
    c.Field(p + "emcy", "count", h.emcy);
    c.Field(p + "bus_off", "count", h.bus_off);
    c.Field(p + "tx_failed", "count", h.tx_failed);
    c.Field(p + "driver_dropped", "count", h.driver_dropped);
    c.Field(p + "wkc_expected", "count", h.wkc_expected);
    c.Field(p + "wkc_received", "count", h.wkc_received);
  }
  c.Field("num_devices", "count", m.num_devices);
  for (int d = 0; d < 16; ++d)
    c.Field("device_state." + std::to_string(d), "enum", m.device_state[d]);
  for (int d = 0; d < 16; ++d)
    c.Field("held_inputs." + std::to_string(d), "count", m.held_inputs[d]);
  for (int d = 0; d < 16; ++d)
    c.Field("max_held_in_row." + std::to_string(d), "count", m.max_held_in_row[d]);
  c.Field("max_held_cycles", "count", m.max_held_cycles);
  c.Field("safety_events", "count", m.safety_events);
  c.Field("snapshots_dropped", "count", m.snapshots_dropped);
  c.Field("events_dropped", "count", m.events_dropped);
  c.Field("snapshots_published", "count", m.snapshots_published);
  c.Field("publish_failures", "count", m.publish_failures);
  c.Field("commands_received", "count", m.commands_received);
  c.Field("commands_accepted", "count", m.commands_accepted);
  c.Field("commands_rejected", "count", m.commands_rejected);
  c.Field("commands_dropped", "count", m.commands_dropped);
  c.Field("commands_unauthenticated", "count", m.commands_unauthenticated);
  c.Field("commands_replayed", "count", m.commands_replayed);
}
void Visit(const hyq_lcm::lcmt_hyq_event& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("cycle", "count", m.cycle);
  c.Field("from_mode", "enum", m.from_mode);
  c.Field("to_mode", "enum", m.to_mode);
  c.Field("from_name", "text", m.from_name);
  c.Field("to_name", "text", m.to_name);
  c.Field("reason_code", "enum", m.reason_code);
  c.Field("reason", "text", m.reason);
  c.Field("joint", "index", m.joint);
  c.Field("bus", "index", m.bus);
  c.Field("detail", "text", m.detail);
}
void Visit(const hyq_lcm::lcmt_hyq_command& m, Csv& c) {
  c.Field("utime", "us", m.utime);
  c.Field("sequence", "count", m.sequence);
  c.Field("kind", "enum", m.kind);
  c.Field("num_feet", "count", m.num_feet);
  for (int f = 0; f < 4; ++f)
    c.Field(std::string("mu.") + kFeet[f], "1",
            f < static_cast<int>(m.mu.size()) ? m.mu[static_cast<std::size_t>(f)] : 0.0);
  c.Field("controller", "text", m.controller);
  c.Field("kp_scale", "1", m.kp_scale);
  c.Field("kd_scale", "1", m.kd_scale);
  c.Field("velocity.vx", "m/s", m.velocity[0]);
  c.Field("velocity.vy", "m/s", m.velocity[1]);
  c.Field("velocity.wz", "rad/s", m.velocity[2]);
}

// the envelope only: the command inside is opaque until the servo has checked its MAC
void Visit(const hyq_lcm::lcmt_hyq_signed_command& m, Csv& c) {
  c.Field("sender", "text", m.sender);
  c.Field("command_size", "bytes", m.command_size);
  char mac[2 * sizeof m.mac + 1];
  for (std::size_t i = 0; i < sizeof m.mac; ++i) std::snprintf(mac + 2 * i, 3, "%02x", m.mac[i]);
  c.Field("mac", "hex", std::string(mac));
}

// The encoding after the fingerprint of the types whose size varies, field by field as lcm-gen
// writes it (lcmtypes/*.lcm). The generated decode trusts a string length (INT32_MIN copies 2 GB)
// and an array count (-1 resizes to SIZE_MAX), so those are checked first; the other types have
// fixed sizes, which the generated decode checks itself. tests/tools/lcm_export_test.cc keeps
// these layouts equal to the generated code.
enum class Wire : std::uint8_t { k1, k2, k8, kCount8, kCount32, kDoubles, kBytes, kMac, kString };
constexpr Wire kEventLayout[] = {Wire::k8,      Wire::k8, Wire::k1,      Wire::k1,
                                 Wire::kString, Wire::kString, Wire::k2, Wire::kString,
                                 Wire::k2,      Wire::k2, Wire::kString};
constexpr Wire kCommandLayout[] = {Wire::k8,      Wire::k8,      Wire::k1, Wire::kCount8,
                                   Wire::kDoubles, Wire::kString, Wire::k8, Wire::k8,
                                   Wire::k8,       Wire::k8,      Wire::k8};
constexpr Wire kSignedCommandLayout[] = {Wire::kString, Wire::kCount32, Wire::kBytes, Wire::kMac};

template <class T>
constexpr std::span<const Wire> kLayout{};
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_event> = kEventLayout;
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_command> = kCommandLayout;
template <>
constexpr std::span<const Wire> kLayout<hyq_lcm::lcmt_hyq_signed_command> = kSignedCommandLayout;

std::int32_t Be32(const std::uint8_t* b) {
  return static_cast<std::int32_t>((std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) |
                                   (std::uint32_t{b[2]} << 8) | std::uint32_t{b[3]});
}

// true when every length field of `data` (fingerprint first) fits and nothing is left over
bool LengthsFit(std::span<const Wire> layout, std::span<const std::uint8_t> data) {
  std::size_t pos = 8;
  std::size_t count = 0;
  auto take = [&](std::size_t n) {
    if (data.size() - pos < n) return false;
    pos += n;
    return true;
  };
  for (const Wire w : layout) {
    bool ok = true;
    switch (w) {
      case Wire::k1: ok = take(1); break;
      case Wire::k2: ok = take(2); break;
      case Wire::k8: ok = take(8); break;
      case Wire::kCount8: {
        ok = take(1);
        const auto n = ok ? static_cast<std::int8_t>(data[pos - 1]) : std::int8_t{-1};
        ok = n >= 0;
        count = ok ? static_cast<std::size_t>(n) : 0;
        break;
      }
      case Wire::kCount32: {
        ok = take(4);
        const std::int32_t n = ok ? Be32(data.data() + pos - 4) : -1;
        ok = n >= 0;
        count = ok ? static_cast<std::size_t>(n) : 0;
        break;
      }
      case Wire::kDoubles: ok = count <= data.size() / 8 && take(8 * count); break;
      case Wire::kBytes: ok = take(count); break;
      case Wire::kMac: ok = take(32); break;
      case Wire::kString: {
        // int32 length including the terminating NUL, then the bytes
        ok = take(4);
        const std::int32_t n = ok ? Be32(data.data() + pos - 4) : 0;
        ok = n >= 1 && take(static_cast<std::size_t>(n));
        break;
      }
    }
    if (!ok) return false;
  }
  return pos == data.size();
}

template <class T>
bool Cells(std::span<const std::uint8_t> data, bool header, std::string* line) {
  T msg{};
  if (!header) {
    if (data.size() < 8 || data.size() > INT_MAX) return false;
    if (!kLayout<T>.empty() && !LengthsFit(kLayout<T>, data)) return false;
    const int size = static_cast<int>(data.size());
    try {
      if (msg.decode(data.data(), 0, size) != size) return false;
    } catch (const std::exception&) {  // std::bad_alloc, or a length the check above missed
      return false;
    }
  }
  std::string cells;
  Csv csv(header, &cells);
  Visit(msg, csv);
  *line = std::move(cells);
  return true;
}

template <class T>
RowType Type(const char* name) {
  return RowType{name, T::getHash(), &Cells<T>};
}

}  // namespace

const RowType* FindRowType(std::span<const std::uint8_t> data) {
  static const std::array<RowType, 12> kTypes = {
      Type<hyq_lcm::lcmt_hyq_joint_state>("lcmt_hyq_joint_state"),
      Type<hyq_lcm::lcmt_hyq_joint_torque>("lcmt_hyq_joint_torque"),
      Type<hyq_lcm::lcmt_hyq_base_state>("lcmt_hyq_base_state"),
      Type<hyq_lcm::lcmt_hyq_contact_state>("lcmt_hyq_contact_state"),
      Type<hyq_lcm::lcmt_hyq_friction_estimate>("lcmt_hyq_friction_estimate"),
      Type<hyq_lcm::lcmt_hyq_disturbance_estimate>("lcmt_hyq_disturbance_estimate"),
      Type<hyq_lcm::lcmt_hyq_servo_timing>("lcmt_hyq_servo_timing"),
      Type<hyq_lcm::lcmt_hyq_sim_truth>("lcmt_hyq_sim_truth"),
      Type<hyq_lcm::lcmt_hyq_health>("lcmt_hyq_health"),
      Type<hyq_lcm::lcmt_hyq_event>("lcmt_hyq_event"),
      Type<hyq_lcm::lcmt_hyq_command>("lcmt_hyq_command"),
      Type<hyq_lcm::lcmt_hyq_signed_command>("lcmt_hyq_signed_command"),
  };
  if (data.size() < 8) return nullptr;
  std::uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | data[static_cast<std::size_t>(i)];
  for (const RowType& t : kTypes)
    if (t.fingerprint == static_cast<std::int64_t>(h)) return &t;
  return nullptr;
}

std::string HeaderCells(const RowType& type) {
  std::string line;
  type.cells({}, true, &line);
  return line;
}

bool RowCells(const RowType& type, std::span<const std::uint8_t> data, std::string* line) {
  return type.cells(data, false, line);
}

}  // namespace hyq::lcm_export
