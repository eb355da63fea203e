#include "servo/command/command_channel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

namespace hyq::servo {

std::int64_t ReadBigEndian(const std::uint8_t* p, int bytes) noexcept {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  if (bytes < 8 && (v & (std::uint64_t{1} << (8 * bytes - 1))) != 0)
    v |= ~std::uint64_t{0} << (8 * bytes);  // sign-extend
  return static_cast<std::int64_t>(v);
}

bool DecodeCommand(const void* data, std::size_t size, hyq_lcm::lcmt_hyq_command* msg, char* why,
                   std::size_t n) noexcept {
  // layout (lcm-gen, big endian): hash 8, utime 8, sequence 8, kind 1, num_feet 1,
  // mu 8 × num_feet, controller: int32 length (incl. NUL) + bytes, kp_scale 8, kd_scale 8,
  // velocity 3 × 8
  const auto* b = static_cast<const unsigned char*>(data);
  constexpr std::size_t kFeetAt = 25, kFixedHead = 26, kTail = 16 + 24;
  if (size < kFixedHead + 4 + 1 + kTail || size > (1u << 16)) {
    std::snprintf(why, n, "message: expected lcmt_hyq_command (%zu..65536 bytes), found %zu bytes",
                  kFixedHead + 4 + 1 + kTail, size);
    return false;
  }
  const auto feet = static_cast<std::int8_t>(b[kFeetAt]);
  const std::size_t len_at = kFixedHead + 8 * static_cast<std::size_t>(feet < 0 ? 0 : feet);
  if (feet < 0 || len_at + 4 > size) {
    std::snprintf(why, n, "num_feet: expected 0..%zu, found %d", (size - kFixedHead - 4) / 8,
                  static_cast<int>(feet));
    return false;
  }
  const std::int64_t text = ReadBigEndian(b + len_at, 4);
  const std::int64_t room = static_cast<std::int64_t>(size - len_at - 4 - kTail);
  if (text < 1 || text > room) {
    std::snprintf(why, n, "controller: expected a string length of 1..%lld bytes, found %lld",
                  static_cast<long long>(room), static_cast<long long>(text));
    return false;
  }
  try {
    if (msg->decode(data, 0, static_cast<int>(size)) < 0) {
      std::snprintf(why, n, "message: expected lcmt_hyq_command, found %zu undecodable bytes", size);
      return false;
    }
  } catch (...) {
    std::snprintf(why, n, "message: expected lcmt_hyq_command, found %zu bytes the decoder refused",
                  size);
    return false;
  }
  return true;
}

CommandValidator::CommandValidator(const CommandChannelConfig& c) : config_(c) {
  if (c.enabled) CheckRanges(c);
  for (const std::string& name : c.allowed_controllers) {
    const auto kind = ParseControllerKind(name);
    if (!kind)
      throw std::invalid_argument("CommandChannelConfig.allowed_controllers: unknown controller '" +
                                  name + "' (expected pid, noslip, stage1 or two_stage)");
    allowed_.push_back(*kind);
  }
}

void CommandValidator::CheckRanges(const CommandChannelConfig& c) {
  if (!(c.max_rate_hz > 0.0))
    throw std::invalid_argument("CommandChannelConfig.max_rate_hz: expected > 0, found " +
                                std::to_string(c.max_rate_hz));
  if (!(c.mu_min <= c.mu_max) || !(c.mu_min >= 0.0))
    throw std::invalid_argument("CommandChannelConfig mu range: expected 0 <= mu_min <= mu_max");
  if (!(c.gain_scale_min <= c.gain_scale_max) || !(c.gain_scale_min > 0.0))
    throw std::invalid_argument(
        "CommandChannelConfig gain scale range: expected 0 < gain_scale_min <= gain_scale_max");
  for (std::size_t i = 0; i < 3; ++i)
    if (!(c.max_velocity[i] >= 0.0) || !std::isfinite(c.max_velocity[i]))
      throw std::invalid_argument("CommandChannelConfig.max_velocity[" + std::to_string(i) +
                                  "]: expected a finite value >= 0, found " +
                                  std::to_string(c.max_velocity[i]));
  if (!IsPlainChannelName(c.channel))
    throw std::invalid_argument("CommandChannelConfig.channel: expected a plain channel name "
                                "([A-Za-z0-9_]+; LCM would read a pattern as a regular expression), "
                                "found '" + c.channel + "'");
  if (!(c.max_age_ms >= 1.0 && c.max_age_ms <= 60000.0))
    throw std::invalid_argument("CommandChannelConfig.max_age_ms: expected 1..60000, found " +
                                std::to_string(c.max_age_ms));
  if (c.max_senders < 1 || c.max_senders > 1024)
    throw std::invalid_argument("CommandChannelConfig.max_senders: expected 1..1024, found " +
                                std::to_string(c.max_senders));
}

bool IsPlainChannelName(const std::string& name) noexcept {
  if (name.empty() || name.size() > 63) return false;
  for (const char ch : name) {
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') ||
                    ch == '_';
    if (!ok) return false;
  }
  return true;
}

bool CommandValidator::Validate(const hyq_lcm::lcmt_hyq_command& msg, ServoCommand* out,
                                char* why, std::size_t n) const {
  const CommandChannelConfig& c = config_;
  using K = hyq_lcm::lcmt_hyq_command;
  if (msg.kind < K::KIND_ENABLE || msg.kind > K::KIND_SET_VELOCITY) {
    std::snprintf(why, n, "kind: expected 0..%d, found %d", K::KIND_SET_VELOCITY, msg.kind);
    return false;
  }
  out->kind = static_cast<ServoCommand::Kind>(msg.kind);
  out->sequence = static_cast<std::uint64_t>(msg.sequence);
  switch (msg.kind) {
    case K::KIND_SET_MU:
      if (msg.num_feet != kNumFeet) {
        std::snprintf(why, n, "mu: expected %d feet, found %d", kNumFeet, msg.num_feet);
        return false;
      }
      for (int f = 0; f < kNumFeet; ++f) {
        const double mu = msg.mu[static_cast<std::size_t>(f)];
        if (!std::isfinite(mu) || mu < c.mu_min || mu > c.mu_max) {
          std::snprintf(why, n, "mu[%d]: expected [%g, %g], found %g", f, c.mu_min, c.mu_max, mu);
          return false;
        }
        out->mu[static_cast<std::size_t>(f)] = mu;
      }
      break;
    case K::KIND_SET_CONTROLLER: {
      const auto kind = ParseControllerKind(msg.controller);
      if (!kind || std::find(allowed_.begin(), allowed_.end(), *kind) == allowed_.end()) {
        std::string list;
        for (const std::string& a : c.allowed_controllers) list += (list.empty() ? "" : ",") + a;
        std::snprintf(why, n, "controller: expected one of %s, found '%.24s'", list.c_str(),
                      msg.controller.c_str());
        return false;
      }
      out->controller = *kind;
      break;
    }
    case K::KIND_SET_GAINS:
      for (const auto& [name, v] : {std::pair{"kp_scale", msg.kp_scale}, {"kd_scale", msg.kd_scale}}) {
        if (!std::isfinite(v) || v < c.gain_scale_min || v > c.gain_scale_max) {
          std::snprintf(why, n, "%s: expected [%g, %g], found %g", name, c.gain_scale_min,
                        c.gain_scale_max, v);
          return false;
        }
      }
      out->kp_scale = msg.kp_scale;
      out->kd_scale = msg.kd_scale;
      break;
    case K::KIND_SET_VELOCITY: {
      constexpr const char* kNames[3] = {"velocity.vx", "velocity.vy", "velocity.wz"};
      constexpr const char* kUnits[3] = {"m/s", "m/s", "rad/s"};
      for (std::size_t i = 0; i < 3; ++i) {
        const double v = msg.velocity[i], lim = c.max_velocity[i];
        if (!std::isfinite(v) || v < -lim || v > lim) {
          std::snprintf(why, n, "%s: expected [%g, %g] %s, found %g", kNames[i], -lim, lim,
                        kUnits[i], v);
          return false;
        }
        out->velocity[i] = v;
      }
      break;
    }
    default:
      break;
  }
  return true;
}

bool CommandValidator::RateAllows(Clock::time_point now, char* why, std::size_t n) const {
  if (!accepted_any_) return true;
  const double dt_s = std::chrono::duration<double>(now - last_accepted_).count();
  if (dt_s * config_.max_rate_hz >= 1.0) return true;
  std::snprintf(why, n, "rate: expected <= %g Hz, found %.0f Hz", config_.max_rate_hz,
                dt_s > 0.0 ? 1.0 / dt_s : 1e9);
  return false;
}

void CommandValidator::Accepted(Clock::time_point now) noexcept {
  accepted_any_ = true;
  last_accepted_ = now;
}

}  // namespace hyq::servo
