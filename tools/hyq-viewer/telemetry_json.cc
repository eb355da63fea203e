#include "tools/hyq-viewer/telemetry_json.h"

#include <climits>
#include <exception>
#include <string_view>

#include "tools/hyq-lcm-export/csv_rows.h"

namespace hyq::viewer {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxEventsPerFrame = 256;
constexpr std::size_t kSeenEventsKept = 4096;
constexpr std::size_t kRecentEvents = 12;

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

// the values the page derives from a message's fields
void AddDerived(const hyq_lcm::lcmt_hyq_joint_state& m, json* j) { (*j)["mode_name"] = ModeName(m.mode); }
void AddDerived(const hyq_lcm::lcmt_hyq_contact_state& m, json* j) {
  int stance = 0;
  for (int f = 0; f < 4; ++f) stance += m.stance_estimated[f] != 0 ? 1 : 0;
  (*j)["stance_count"] = stance;
  (*j)["qp_solve_us"] = m.stage1_solve_us + m.stage2_solve_us;
}
template <class T>
void AddDerived(const T& /*m*/, json* /*j*/) {}

// One type the page draws, under its "kind".
struct Kind {
  const char* kind;
  std::int64_t fingerprint;
  // a state: only the latest one is kept, and checked (no JSON) as it arrives; for a contact
  // message the check also gives its QP time (µs). Null for an event: every one is kept.
  bool (*check)(std::span<const std::uint8_t> data, double* qp_solve_us);
  std::optional<json> (*to_json)(std::span<const std::uint8_t> data);
};

template <class T>
bool Check(std::span<const std::uint8_t> data, double* /*qp_solve_us*/) {
  T msg{};
  return Decode(data, &msg);
}
template <>
bool Check<hyq_lcm::lcmt_hyq_contact_state>(std::span<const std::uint8_t> data, double* qp_solve_us) {
  hyq_lcm::lcmt_hyq_contact_state m{};
  if (!Decode(data, &m)) return false;
  *qp_solve_us = m.stage1_solve_us + m.stage2_solve_us;
  return true;
}

template <class T>
std::optional<json> Json(std::span<const std::uint8_t> data) {
  T msg{};
  if (!Decode(data, &msg)) return std::nullopt;
  json j = ToJson(msg);
  AddDerived(msg, &j);
  return j;
}

// the generated decoder trusts the string lengths: hyq-lcm-export's checks go first
std::optional<json> EventJson(std::span<const std::uint8_t> data) {
  const lcm_export::RowType* type = lcm_export::FindRowType(data);
  std::string unused;
  if (type == nullptr || !lcm_export::RowCells(*type, data, &unused)) return std::nullopt;
  return Json<hyq_lcm::lcmt_hyq_event>(data);
}

template <class T>
Kind State(const char* kind) {
  return {kind, T::getHash(), &Check<T>, &Json<T>};
}

const Kind* FindKind(std::span<const std::uint8_t> data) {
  static const Kind kKinds[] = {
      State<hyq_lcm::lcmt_hyq_joint_state>("joint"),
      State<hyq_lcm::lcmt_hyq_base_state>("base"),
      State<hyq_lcm::lcmt_hyq_contact_state>("contact"),
      State<hyq_lcm::lcmt_hyq_friction_estimate>("friction"),
      State<hyq_lcm::lcmt_hyq_servo_timing>("timing"),
      State<hyq_lcm::lcmt_hyq_joint_torque>("torque"),
      State<hyq_lcm::lcmt_hyq_sim_truth>("truth"),
      {"event", hyq_lcm::lcmt_hyq_event::getHash(), nullptr, &EventJson},
  };
  if (data.size() < 8) return nullptr;
  const std::int64_t h = Fingerprint(data);
  for (const Kind& k : kKinds)
    if (k.fingerprint == h) return &k;
  return nullptr;
}

// the "kind" of a well-formed state message (cheap: no JSON), null for anything else; for a
// contact message also its QP time (µs)
const char* StateKind(std::span<const std::uint8_t> data, double* qp_solve_us) {
  const Kind* k = FindKind(data);
  return k != nullptr && k->check != nullptr && k->check(data, qp_solve_us) ? k->kind : nullptr;
}

}  // namespace

std::string ModeName(int mode) {
  static const char* const kNames[] = {"init", "standby", "active", "damping", "fault", "stopped"};
  if (mode >= 0 && mode < 6) return kNames[mode];
  return "mode " + std::to_string(mode);
}

std::optional<json> DecodeMessage(std::span<const std::uint8_t> data) {
  const Kind* k = FindKind(data);
  if (k == nullptr) return std::nullopt;
  std::optional<json> out = k->to_json(data);
  if (out) (*out)["kind"] = k->kind;
  return out;
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
