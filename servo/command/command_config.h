// The operator command channel's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `commands.*` of config/hyq_servo.yaml).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "hal/config_key.h"
#include "servo/common/servo_types.h"

namespace hyq::servo {

/// A channel name LCM reads as it is (LCM subscribes by regular expression); in command_channel.cc.
bool IsPlainChannelName(const std::string& name) noexcept;

/// A bound in a message, without trailing zeros ("0.05").
inline std::string FormatBound(double x) {
  std::string s = std::to_string(x);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

/// The operator command channel (lcmt_hyq_signed_command carrying an lcmt_hyq_command; see
/// docs/security.md). Off unless enabled; when off, no subscription exists at all.
struct CommandChannelConfig {
  bool enabled = false;
  std::string channel = "HYQ_COMMAND";
  std::string key_file = "/etc/hyq/command.key";  // the robot's key (hyq-command --generate-key)
  double max_age_ms = 1000.0;            // a command's utime within this of the robot's clock
  std::size_t max_senders = 16;          // distinct senders whose last sequence is remembered
  /// The interface the command group must be joined on (the routing table decides it for liblcm);
  /// a different one is a start-up error. Empty: not checked.
  std::string interface = "lo";
  double max_rate_hz = 20.0;             // accepted commands at most this often; faster ones are refused
  double mu_min = 0.0, mu_max = 2.0;     // accepted friction range (inclusive)
  double gain_scale_min = 0.1, gain_scale_max = 2.0;  // accepted kp/kd multipliers (inclusive)
  /// accepted |vx| m/s, |vy| m/s, |wz| rad/s of a set-velocity command (inclusive)
  std::array<double, 3> max_velocity{0.4, 0.2, 0.5};
  std::vector<std::string> allowed_controllers = {"pid", "noslip", "stage1", "two_stage", "pd_gravity"};

  template <class A>
  void Serialize(A* a) {
    a->Visit(hal::Key("enabled", &enabled).Doc("the LCM command channel exists only when enabled"));
    a->Visit(hal::Key("channel", &channel)
                 .Check([](const std::string& c) -> std::optional<hal::Violation> {
                   if (!IsPlainChannelName(c))
                     return hal::Violation{"a plain channel name [A-Za-z0-9_]+ (LCM reads a pattern as a "
                                           "regular expression)"};
                   return std::nullopt;
                 })
                 .Doc("the channel commands arrive on (not one the telemetry publishes on)"));
    a->Visit(hal::Key("key_file", &key_file).Path()
                 .Doc("the robot's key, readable by its owner alone (docs/security.md)"));
    a->Visit(hal::Key("max_age_ms", &max_age_ms).In(1.0, 60000.0).Unit("ms")
                 .Doc("a command's time within this of the robot's clock"));
    a->Visit(hal::Key("max_senders", &max_senders).In(1, 1024)
                 .Doc("distinct senders whose last sequence number is remembered"));
    a->Visit(hal::Key("interface", &interface)
                 .Doc("the command group must route via this network interface"));
    a->Visit(hal::Key("max_rate_hz", &max_rate_hz).In(0.1, 1000.0).Unit("Hz")
                 .Doc("accepted commands at most this often"));
    a->Visit(hal::Key("mu_min", &mu_min).In(0.0, 10.0).Doc("accepted friction range: lowest"));
    a->Visit(hal::Key("mu_max", &mu_max).In(0.0, 10.0)
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v < mu_min) return hal::Violation{"mu_max >= mu_min (" + FormatBound(mu_min) + ")"};
                   return std::nullopt;
                 })
                 .Doc("accepted friction range: highest"));
    a->Visit(hal::Key("gain_scale_min", &gain_scale_min).In(1e-3, 100.0)
                 .Doc("accepted kp/kd multipliers: lowest"));
    a->Visit(hal::Key("gain_scale_max", &gain_scale_max).In(1e-3, 100.0)
                 .Check([this](const double& v) -> std::optional<hal::Violation> {
                   if (v < gain_scale_min)
                     return hal::Violation{"gain_scale_max >= gain_scale_min (" + FormatBound(gain_scale_min) + ")"};
                   return std::nullopt;
                 })
                 .Doc("accepted kp/kd multipliers: highest"));
    a->Visit(hal::Key("max_velocity", &max_velocity).In(0.0, 1.0).MaxEach({1.0, 0.5, 1.5})
                 .Elements("[vx, vy, wz]").Unit("m/s, m/s, rad/s")
                 .Doc("set-velocity commands accepted up to |vx|, |vy|, |wz|"));
    a->Visit(hal::Key("allowed_controllers", &allowed_controllers)
                 .Check([](const std::vector<std::string>& names) -> std::optional<hal::Violation> {
                   for (std::size_t i = 0; i < names.size(); ++i)
                     if (!ParseControllerKind(names[i])) {
                       std::string expected = "one of";
                       for (const auto& c : ControllerKindChoices())
                         expected.append(expected == "one of" ? " " : ", ").append(c.name);
                       return hal::Violation{expected, static_cast<int>(i)};
                     }
                   return std::nullopt;
                 })
                 .Doc("the controllers a command may switch to"));
  }
};

}  // namespace hyq::servo
