#include "tools/hyq-viewer/log_player.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>

#include "tools/hyq-lcm-export/lcm_log.h"

namespace hyq::viewer {

namespace {
constexpr double kMinSpeed = 0.05, kMaxSpeed = 20.0;
// a seek replays this much log before the target, so that every state has a message
constexpr double kPrimeWindow_s = 0.5;
}  // namespace

LogPlayer::LogPlayer(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("--log: cannot read '" + path + "'");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::set<std::string_view> wanted(std::begin(kChannels), std::end(kChannels));
  lcm_export::LogReader reader(bytes);
  lcm_export::LogEvent e;
  std::int64_t first_us = 0;
  while (reader.Next(&e)) {
    if (!wanted.contains(e.channel)) continue;
    if (events_.empty()) first_us = e.timestamp_us;
    events_.push_back({e.timestamp_us - first_us, std::string(e.channel),
                       std::vector<std::uint8_t>(e.data.begin(), e.data.end())});
  }
  skipped_bytes_ = reader.damage().skipped_bytes;
  if (events_.empty())
    throw std::runtime_error("--log: '" + path + "' holds no message on a viewer channel (HYQ_JOINT_STATE, ...)");
  // lcm-logger stamps in arrival order; keep playback monotonic even if a clock stepped back
  std::stable_sort(events_.begin(), events_.end(), [](const Event& a, const Event& b) { return a.t_us < b.t_us; });
}

double LogPlayer::TimeAt(double now_s) const {
  if (anchor_wall_s_ < 0 || paused_) return anchor_log_s_;
  return anchor_log_s_ + (now_s - anchor_wall_s_) * speed_;
}

void LogPlayer::Advance(double now_s, TelemetryModel* model) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (anchor_wall_s_ < 0) anchor_wall_s_ = now_s;
  const double duration_s = 1e-6 * static_cast<double>(events_.back().t_us);
  double t = TimeAt(now_s);
  if (t >= duration_s) {  // the end: stay there, paused
    t = duration_s;
    paused_ = true;
    anchor_log_s_ = t;
    anchor_wall_s_ = now_s;
  }
  const auto t_us = static_cast<std::int64_t>(std::llround(t * 1e6));
  while (next_ < events_.size() && events_[next_].t_us <= t_us) {
    model->Feed(events_[next_].channel, events_[next_].data);
    ++next_;
  }
}

bool LogPlayer::Control(const std::string& text, double now_s, TelemetryModel* model) {
  const nlohmann::json msg = nlohmann::json::parse(text, nullptr, false);
  if (msg.is_discarded() || !msg.is_object() || !msg.contains("cmd") || !msg["cmd"].is_string()) return false;
  const std::string cmd = msg["cmd"].get<std::string>();
  std::lock_guard<std::mutex> lock(mutex_);
  const double duration_s = 1e-6 * static_cast<double>(events_.back().t_us);
  if (cmd == "pause") {
    anchor_log_s_ = TimeAt(now_s);
    anchor_wall_s_ = now_s;
    paused_ = true;
    return true;
  }
  if (cmd == "resume") {
    if (anchor_log_s_ >= duration_s) SeekLocked(0.0, model);  // from the start again
    anchor_wall_s_ = now_s;
    paused_ = false;
    return true;
  }
  if (cmd == "seek") {
    if (!msg.contains("t_s") || !msg["t_s"].is_number()) return false;
    const double t = msg["t_s"].get<double>();
    if (!std::isfinite(t)) return false;
    SeekLocked(std::clamp(t, 0.0, duration_s), model);
    anchor_wall_s_ = now_s;
    return true;
  }
  if (cmd == "speed") {
    if (!msg.contains("speed") || !msg["speed"].is_number()) return false;
    const double x = msg["speed"].get<double>();
    if (!std::isfinite(x) || x < kMinSpeed || x > kMaxSpeed) return false;
    anchor_log_s_ = TimeAt(now_s);
    anchor_wall_s_ = now_s;
    speed_ = x;
    return true;
  }
  return false;
}

void LogPlayer::SeekLocked(double t_s, TelemetryModel* model) {
  model->Reset();
  const auto t_us = static_cast<std::int64_t>(std::llround(t_s * 1e6));
  const auto from_us = static_cast<std::int64_t>(std::llround((t_s - kPrimeWindow_s) * 1e6));
  auto by_time = [](const Event& e, std::int64_t t) { return e.t_us < t; };
  std::size_t i = static_cast<std::size_t>(
      std::lower_bound(events_.begin(), events_.end(), from_us, by_time) - events_.begin());
  for (; i < events_.size() && events_[i].t_us <= t_us; ++i) model->Feed(events_[i].channel, events_[i].data);
  next_ = i;
  anchor_log_s_ = t_s;
}

nlohmann::json LogPlayer::Status(double now_s) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const double duration_s = 1e-6 * static_cast<double>(events_.back().t_us);
  return {{"t_s", std::min(TimeAt(now_s), duration_s)},
          {"duration_s", duration_s},
          {"paused", paused_},
          {"speed", speed_},
          {"messages", events_.size()}};
}

}  // namespace hyq::viewer
