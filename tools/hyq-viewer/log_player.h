// hyq-viewer --log: plays an lcm-logger file into a TelemetryModel at the speed it was recorded
// (times the chosen speed), with pause, resume and seek. The log is read whole at start with
// hyq-lcm-export's damage-tolerant reader (tools/hyq-lcm-export/lcm_log.h); only the channels
// the viewer shows are kept.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tools/hyq-viewer/telemetry_json.h"

namespace hyq::viewer {

class LogPlayer {
 public:
  /// Reads `path`; throws std::runtime_error naming it when it cannot be read or holds no
  /// message of a viewer channel.
  explicit LogPlayer(const std::string& path);

  /// Starts paused (the page or a Control() message resumes it).
  void StartPaused() { paused_ = true; }

  /// Feeds `model` with every message due at `now_s` (a monotonic wall clock, s).
  void Advance(double now_s, TelemetryModel* model);

  /// A browser's control message: {"cmd": "pause"|"resume"|"seek"|"speed", "t_s": S, "speed": X}.
  /// False (ignored) when it is none of those or a value is out of range.
  bool Control(const std::string& text, double now_s, TelemetryModel* model);

  /// {"t_s", "duration_s", "paused", "speed", "messages"} for the page.
  nlohmann::json Status(double now_s) const;

  std::size_t size() const noexcept { return events_.size(); }
  std::uint64_t damaged_bytes() const noexcept { return skipped_bytes_; }

 private:
  struct Event {
    std::int64_t t_us;  // from the first kept event
    std::string channel;
    std::vector<std::uint8_t> data;
  };
  // the log time at now_s
  double TimeAt(double now_s) const;
  void SeekLocked(double t_s, TelemetryModel* model);

  std::vector<Event> events_;
  std::uint64_t skipped_bytes_ = 0;
  mutable std::mutex mutex_;
  std::size_t next_ = 0;        // the first event not yet fed
  double anchor_log_s_ = 0.0;   // log time at anchor_wall_s_
  double anchor_wall_s_ = -1.0; // < 0: not started
  double speed_ = 1.0;
  bool paused_ = false;
};

}  // namespace hyq::viewer
