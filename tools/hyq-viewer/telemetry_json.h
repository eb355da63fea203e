// hyq-viewer's model of the telemetry: LCM messages in (any hyq_lcm type the page draws,
// recognised by its fingerprint), one JSON frame out per display tick. A message's JSON holds
// every field of its list (lcmtypes/telemetry_fields.h, through JsonArchive) plus the few values
// the page derives from them (mode_name, stance_count, qp_solve_us). States keep only their
// latest message (the page wants the present, at 30-60 Hz, not the servo's 1 kHz); events are
// all kept until the next frame, deduplicated (the daemon repeats each one, docs/telemetry.md).
// Never throws on bad input: a malformed message is counted and dropped.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "lcmtypes/telemetry_fields.h"

namespace hyq::viewer {

/// Writes one message as a JSON object keyed by the field names of its Serialize: numbers as numbers, "bool" fields as true/false, arrays as arrays (a 2-D one as an
/// array of arrays, an array of messages as an array of objects), strings as printable ASCII
/// (the wire's strings may hold any bytes; others become '?'), byte arrays as hex.
class JsonArchive {
 public:
  explicit JsonArchive(nlohmann::json* out) : out_(out) {}

  template <class T>
  void Visit(const char* name, const char* unit, const T* value) {
    (*out_)[name] = Value(unit, *value);
  }
  template <class T, std::size_t N>
  void Visit(const char* name, const char* unit, const T (*values)[N],
             const char* const (&/*labels*/)[N]) {
    (*out_)[name] = Array(unit, *values);
  }
  template <class T, std::size_t N, std::size_t M>
  void Visit(const char* name, const char* unit, const T (*values)[N][M],
             const char* const (&/*labels*/)[N], const char* const (&/*labels2*/)[M]) {
    nlohmann::json a = nlohmann::json::array();
    for (std::size_t i = 0; i < N; ++i) a.push_back(Array(unit, (*values)[i]));
    (*out_)[name] = std::move(a);
  }
  template <class T, std::size_t N>
  void Visit(const char* name, const char* unit, const std::vector<T>* values,
             const char* const (&/*labels*/)[N]) {
    nlohmann::json a = nlohmann::json::array();
    for (const T& v : *values) a.push_back(Value(unit, v));
    (*out_)[name] = std::move(a);
  }
  template <std::size_t N>
  void Visit(const char* name, const char* /*unit*/, const std::uint8_t (*bytes)[N]) {
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    for (std::uint8_t b : *bytes) {
      hex += kHex[b >> 4];
      hex += kHex[b & 0xf];
    }
    (*out_)[name] = hex;
  }
  template <class S, std::size_t N>
  void Visit(const char* name, const S (*structs)[N], const char* const (&/*labels*/)[N]) {
    nlohmann::json a = nlohmann::json::array();
    for (const S& s : *structs) {
      nlohmann::json element = nlohmann::json::object();
      JsonArchive inner(&element);
      Serialize(&inner, const_cast<S*>(&s));
      a.push_back(std::move(element));
    }
    (*out_)[name] = std::move(a);
  }

 private:
  template <class T>
  static nlohmann::json Value(const char* unit, const T& v) {
    if constexpr (std::is_same_v<T, std::string>) {
      std::string out;
      for (unsigned char c : v) out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
      return out;
    } else if constexpr (std::is_same_v<T, std::int8_t>) {
      if (std::string_view(unit) == "bool") return v != 0;
      return v;
    } else {
      return v;
    }
  }
  template <class T, std::size_t N>
  static nlohmann::json Array(const char* unit, const T (&values)[N]) {
    nlohmann::json a = nlohmann::json::array();
    for (const T& v : values) a.push_back(Value(unit, v));
    return a;
  }

  nlohmann::json* out_;
};

/// Every field of one message, as JsonArchive writes them.
template <class T>
nlohmann::json ToJson(const T& msg) {
  nlohmann::json out = nlohmann::json::object();
  JsonArchive a(&out);
  Serialize(&a, const_cast<T*>(&msg));  // JsonArchive only reads
  return out;
}

/// The channels the viewer subscribes to (live mode) and plays (log mode).
inline constexpr const char* kChannels[] = {
    "HYQ_JOINT_STATE", "HYQ_BASE_STATE", "HYQ_CONTACT", "HYQ_FRICTION", "HYQ_TIMING",
    "HYQ_EVENT",       "HYQ_JOINT_TORQUE", "HYQ_SIM_TRUTH"};

/// Name of servo::ServoMode `mode` ("active", ...), "mode N" for an unknown value.
std::string ModeName(int mode);

/// One decoded message as JSON: {"kind": "joint"|"base"|"contact"|"friction"|"timing"|"event"|
/// "torque"|"truth", ...fields with their units in the names}. Empty when `data` is no
/// well-formed message of one of those types.
std::optional<nlohmann::json> DecodeMessage(std::span<const std::uint8_t> data);

/// Latest state per kind plus the events since the last frame.
class TelemetryModel {
 public:
  /// Feeds one message received on `channel`; false (and counted) when it does not decode.
  bool Feed(const std::string& channel, std::span<const std::uint8_t> data);

  /// The frame for the page: {"type": "frame", "seq", "<kind>": {...} for each state seen,
  /// "events": [...] new since the last frame, "recent_events": the last 12 (newest last),
  /// "stats": {...}, "qp_solve_max_us": max of
  /// stage1+stage2 over the messages since the last frame}. Clears the new events.
  nlohmann::json TakeFrame();

  /// Forgets the states and events (a log seek); counters stay.
  void Reset();

  std::uint64_t messages() const noexcept { return messages_; }
  std::uint64_t undecodable() const noexcept { return undecodable_; }

 private:
  std::map<std::string, std::vector<std::uint8_t>> latest_;  // kind -> the last well-formed message
  std::deque<nlohmann::json> new_events_;
  std::deque<nlohmann::json> recent_events_;  // the last kRecentEvents, for a page that joins late
  std::set<std::tuple<std::int64_t, int, std::string>> seen_events_;  // (cycle, reason, detail)
  std::deque<std::tuple<std::int64_t, int, std::string>> seen_order_;
  double qp_solve_max_us_ = -1.0;
  std::uint64_t messages_ = 0, undecodable_ = 0, events_dropped_ = 0, seq_ = 0;
  std::map<std::string, std::uint64_t> per_channel_;
};

}  // namespace hyq::viewer
