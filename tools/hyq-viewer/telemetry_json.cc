#include "tools/hyq-viewer/telemetry_json.h"

#include <climits>
#include <exception>
#include <string_view>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_contact_state.hpp"
#include "hyq_lcm/lcmt_hyq_event.hpp"
#include "hyq_lcm/lcmt_hyq_friction_estimate.hpp"
#include "hyq_lcm/lcmt_hyq_joint_state.hpp"
#include "hyq_lcm/lcmt_hyq_joint_torque.hpp"
#include "hyq_lcm/lcmt_hyq_servo_timing.hpp"
#include "hyq_lcm/lcmt_hyq_sim_truth.hpp"
#include "tools/hyq-lcm-export/csv_rows.h"

namespace hyq::viewer {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxEventsPerFrame = 256;
constexpr std::size_t kSeenEventsKept = 4096;
constexpr std::size_t kRecentEvents = 12;

template <class T, std::size_t N>
json Array(const T (&a)[N]) {
  json out = json::array();
  for (std::size_t i = 0; i < N; ++i) out.push_back(a[i]);
  return out;
}
template <std::size_t N>
json Bools(const int8_t (&a)[N]) {
  json out = json::array();
  for (std::size_t i = 0; i < N; ++i) out.push_back(a[i] != 0);
  return out;
}
template <std::size_t N, std::size_t M>
json Array2(const double (&a)[N][M]) {
  json out = json::array();
  for (std::size_t i = 0; i < N; ++i) out.push_back(Array(a[i]));
  return out;
}

// decodes `data` as T: false when it is not exactly one well-formed T
template <class T>
bool Decode(std::span<const std::uint8_t> data, T* msg) {
  if (data.size() < 8 || data.size() > INT_MAX) return false;
  const int size = static_cast<int>(data.size());
  try {
    return msg->decode(data.data(), 0, size) == size;
  } catch (const std::exception&) {
    return false;
  }
}

std::int64_t Fingerprint(std::span<const std::uint8_t> data) {
  std::uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | data[static_cast<std::size_t>(i)];
  return static_cast<std::int64_t>(h);
}

json ToJson(const hyq_lcm::lcmt_hyq_joint_state& m) {
  return {{"kind", "joint"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"mode", m.mode},
          {"mode_name", ModeName(m.mode)},
          {"reference_time_s", m.reference_time_s},
          {"q_rad", Array(m.q_rad)},
          {"qd_rad_s", Array(m.qd_rad_s)},
          {"q_ref_rad", Array(m.q_ref_rad)},
          {"tau_measured_Nm", Array(m.tau_measured_Nm)},
          {"tracking_error_rad", m.tracking_error_rad}};
}
json ToJson(const hyq_lcm::lcmt_hyq_base_state& m) {
  return {{"kind", "base"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"position_m", Array(m.position_m)},
          {"orientation_wxyz", Array(m.orientation_wxyz)},
          {"velocity_m_s", Array(m.velocity_m_s)}};
}
json ToJson(const hyq_lcm::lcmt_hyq_contact_state& m) {
  int stance = 0;
  for (int f = 0; f < 4; ++f) stance += m.stance_estimated[f] != 0 ? 1 : 0;
  return {{"kind", "contact"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"stance_estimated", Bools(m.stance_estimated)},
          {"stance_reference", Bools(m.stance_reference)},
          {"stance_count", stance},
          {"mu", Array(m.mu)},
          {"contact_force_N", Array2(m.contact_force_N)},
          {"fallback", m.fallback},
          {"stage1_solve_us", m.stage1_solve_us},
          {"stage2_solve_us", m.stage2_solve_us},
          {"qp_solve_us", m.stage1_solve_us + m.stage2_solve_us}};
}
json ToJson(const hyq_lcm::lcmt_hyq_friction_estimate& m) {
  return {{"kind", "friction"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"enabled", m.enabled != 0},
          {"mu_estimate", Array(m.mu_estimate)},
          {"mu_control", Array(m.mu_control)},
          {"force_N", Array2(m.force_N)},
          {"loaded", Bools(m.loaded)},
          {"slipping", Bools(m.slipping)},
          {"slips", Array(m.slips)}};
}
json ToJson(const hyq_lcm::lcmt_hyq_servo_timing& m) {
  return {{"kind", "timing"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"total_ns", m.total_ns},
          {"control_ns", m.control_ns},
          {"deadline_misses", m.deadline_misses},
          {"skipped_cycles", m.skipped_cycles}};
}
json ToJson(const hyq_lcm::lcmt_hyq_joint_torque& m) {
  return {{"kind", "torque"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"mode", m.mode},
          {"controller", m.controller},
          {"tau_command_Nm", Array(m.tau_command_Nm)}};
}
json ToJson(const hyq_lcm::lcmt_hyq_sim_truth& m) {
  return {{"kind", "truth"},
          {"utime", m.utime},
          {"step", m.step},
          {"sim_time_s", m.sim_time_s},
          {"position_m", Array(m.position_m)},
          {"orientation_wxyz", Array(m.orientation_wxyz)},
          {"q_rad", Array(m.q_rad)},
          {"contact_force_N", Array2(m.contact_force_N)},
          {"touching", Bools(m.touching)},
          {"mu", Array(m.mu)},
          {"holding", m.holding != 0}};
}
json ToJson(const hyq_lcm::lcmt_hyq_event& m) {
  // strings from the wire may be any bytes: keep them valid UTF-8 for the JSON encoder
  auto text = [](const std::string& s) {
    std::string out;
    for (unsigned char c : s) out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
    return out;
  };
  return {{"kind", "event"},
          {"utime", m.utime},
          {"cycle", m.cycle},
          {"from_mode", m.from_mode},
          {"to_mode", m.to_mode},
          {"from_name", text(m.from_name)},
          {"to_name", text(m.to_name)},
          {"reason_code", m.reason_code},
          {"reason", text(m.reason)},
          {"joint", m.joint},
          {"bus", m.bus},
          {"detail", text(m.detail)}};
}

template <class T>
std::optional<json> Try(std::span<const std::uint8_t> data) {
  T msg{};
  if (!Decode(data, &msg)) return std::nullopt;
  return ToJson(msg);
}

template <class T>
const char* Check(std::span<const std::uint8_t> data, const char* kind) {
  T msg{};
  return Decode(data, &msg) ? kind : nullptr;
}

// the "kind" of a well-formed state message (cheap: no JSON), null for anything else; for a
// contact message also its QP time (µs)
const char* StateKind(std::span<const std::uint8_t> data, double* qp_solve_us) {
  if (data.size() < 8) return nullptr;
  const std::int64_t h = Fingerprint(data);
  if (h == hyq_lcm::lcmt_hyq_joint_state::getHash()) return Check<hyq_lcm::lcmt_hyq_joint_state>(data, "joint");
  if (h == hyq_lcm::lcmt_hyq_base_state::getHash()) return Check<hyq_lcm::lcmt_hyq_base_state>(data, "base");
  if (h == hyq_lcm::lcmt_hyq_friction_estimate::getHash())
    return Check<hyq_lcm::lcmt_hyq_friction_estimate>(data, "friction");
  if (h == hyq_lcm::lcmt_hyq_servo_timing::getHash()) return Check<hyq_lcm::lcmt_hyq_servo_timing>(data, "timing");
  if (h == hyq_lcm::lcmt_hyq_joint_torque::getHash()) return Check<hyq_lcm::lcmt_hyq_joint_torque>(data, "torque");
  if (h == hyq_lcm::lcmt_hyq_sim_truth::getHash()) return Check<hyq_lcm::lcmt_hyq_sim_truth>(data, "truth");
  if (h == hyq_lcm::lcmt_hyq_contact_state::getHash()) {
    hyq_lcm::lcmt_hyq_contact_state m{};
    if (!Decode(data, &m)) return nullptr;
    *qp_solve_us = m.stage1_solve_us + m.stage2_solve_us;
    return "contact";
  }
  return nullptr;
}

}  // namespace

std::string ModeName(int mode) {
  static const char* const kNames[] = {"init", "standby", "active", "damping", "fault", "stopped"};
  if (mode >= 0 && mode < 6) return kNames[mode];
  return "mode " + std::to_string(mode);
}

std::optional<json> DecodeMessage(std::span<const std::uint8_t> data) {
  if (data.size() < 8) return std::nullopt;
  const std::int64_t h = Fingerprint(data);
  if (h == hyq_lcm::lcmt_hyq_joint_state::getHash()) return Try<hyq_lcm::lcmt_hyq_joint_state>(data);
  if (h == hyq_lcm::lcmt_hyq_base_state::getHash()) return Try<hyq_lcm::lcmt_hyq_base_state>(data);
  if (h == hyq_lcm::lcmt_hyq_contact_state::getHash()) return Try<hyq_lcm::lcmt_hyq_contact_state>(data);
  if (h == hyq_lcm::lcmt_hyq_friction_estimate::getHash())
    return Try<hyq_lcm::lcmt_hyq_friction_estimate>(data);
  if (h == hyq_lcm::lcmt_hyq_servo_timing::getHash()) return Try<hyq_lcm::lcmt_hyq_servo_timing>(data);
  if (h == hyq_lcm::lcmt_hyq_joint_torque::getHash()) return Try<hyq_lcm::lcmt_hyq_joint_torque>(data);
  if (h == hyq_lcm::lcmt_hyq_sim_truth::getHash()) return Try<hyq_lcm::lcmt_hyq_sim_truth>(data);
  if (h == hyq_lcm::lcmt_hyq_event::getHash()) {
    // the generated decoder trusts the string lengths: hyq-lcm-export's checks go first
    const lcm_export::RowType* type = lcm_export::FindRowType(data);
    std::string unused;
    if (type == nullptr || !lcm_export::RowCells(*type, data, &unused)) return std::nullopt;
    return Try<hyq_lcm::lcmt_hyq_event>(data);
  }
  return std::nullopt;
}

bool TelemetryModel::Feed(const std::string& channel, std::span<const std::uint8_t> data) {
  ++messages_;
  std::string name;  // a channel from a log may be any bytes: printable ASCII for the JSON
  for (unsigned char c : channel.substr(0, 64)) name += (c > 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  ++per_channel_[name];
  // states: only checked and kept as bytes; TakeFrame() makes JSON of the latest one
  double qp_us = 0.0;
  if (const char* kind = StateKind(data, &qp_us)) {
    if (std::string_view(kind) == "contact" && qp_us > qp_solve_max_us_) qp_solve_max_us_ = qp_us;
    latest_[kind].assign(data.begin(), data.end());
    return true;
  }
  std::optional<json> msg = DecodeMessage(data);
  if (!msg || (*msg)["kind"] != "event") {
    ++undecodable_;
    return false;
  }
  // an event: every one goes out once, repeats (same cycle, reason, detail) are dropped
  auto key = std::make_tuple((*msg)["cycle"].get<std::int64_t>(), (*msg)["reason_code"].get<int>(),
                             (*msg)["detail"].get<std::string>());
  if (!seen_events_.insert(key).second) return true;
  seen_order_.push_back(key);
  if (seen_order_.size() > kSeenEventsKept) {
    seen_events_.erase(seen_order_.front());
    seen_order_.pop_front();
  }
  if (new_events_.size() >= kMaxEventsPerFrame) {
    new_events_.pop_front();
    ++events_dropped_;
  }
  recent_events_.push_back(*msg);
  if (recent_events_.size() > kRecentEvents) recent_events_.pop_front();
  new_events_.push_back(std::move(*msg));
  return true;
}

json TelemetryModel::TakeFrame() {
  json frame = {{"type", "frame"}, {"seq", ++seq_}};
  for (const auto& [kind, bytes] : latest_)
    if (std::optional<json> msg = DecodeMessage(bytes)) frame[kind] = std::move(*msg);
  frame["events"] = json::array();
  for (json& e : new_events_) frame["events"].push_back(std::move(e));
  new_events_.clear();
  frame["recent_events"] = json::array();
  for (const json& e : recent_events_) frame["recent_events"].push_back(e);
  if (qp_solve_max_us_ >= 0) frame["qp_solve_max_us"] = qp_solve_max_us_;
  qp_solve_max_us_ = -1.0;
  json channels = json::object();
  for (const auto& [name, n] : per_channel_) channels[name] = n;
  frame["stats"] = {{"messages", messages_},
                    {"undecodable", undecodable_},
                    {"events_dropped", events_dropped_},
                    {"channels", channels}};
  return frame;
}

void TelemetryModel::Reset() {
  latest_.clear();
  new_events_.clear();
  recent_events_.clear();
  seen_events_.clear();
  seen_order_.clear();
  qp_solve_max_us_ = -1.0;
}

}  // namespace hyq::viewer
