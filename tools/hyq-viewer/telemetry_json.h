// hyq-viewer's model of the telemetry: LCM messages in (any hyq_lcm type the page draws,
// recognised by its fingerprint), one JSON frame out per display tick. States keep only their
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
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

namespace hyq::viewer {

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
