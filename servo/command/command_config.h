// The operator command channel's configuration (house style §1: declared here, filled from YAML by
// config/servo_config_loader.cc, keys `commands.*` of config/hyq_servo.yaml).
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace hyq::servo {

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
  double max_rate_hz = 10.0;             // accepted commands at most this often; faster ones are refused
  double mu_min = 0.0, mu_max = 2.0;     // accepted friction range (inclusive)
  double gain_scale_min = 0.1, gain_scale_max = 2.0;  // accepted kp/kd multipliers (inclusive)
  /// accepted |vx| m/s, |vy| m/s, |wz| rad/s of a set-velocity command (inclusive)
  std::array<double, 3> max_velocity{0.4, 0.2, 0.5};
  std::vector<std::string> allowed_controllers = {"pid", "noslip", "stage1", "two_stage", "pd_gravity"};
};

}  // namespace hyq::servo
