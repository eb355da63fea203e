// hyq-command: sends one operator command (lcmt_hyq_command) to the servo's command channel.
#include <chrono>
#include <cstdio>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "servo/command/command_auth.h"
#include "tools/cli/command_line.h"

namespace {

constexpr const char* kUsage = R"(usage: hyq-command [--key FILE] [--sender NAME] [--lcm-url URL] [--channel NAME] COMMAND
       hyq-command --generate-key FILE

Sends one command to the HyQ servo's command channel, signed with the robot's key
(lcmt_hyq_signed_command around an lcmt_hyq_command; docs/security.md). The servo accepts it
only if its command channel is enabled, the signature holds, the command is fresh (its time within
commands.max_age_ms of the robot's clock) and its sequence is above the last one taken from this
sender. Refusals (bad values, too fast, not authentic) are published on HYQ_EVENT with the field,
what was expected and what was found (watch them with hyq-spy).

commands:
  enable                 STANDBY -> ACTIVE
  disable                ACTIVE -> STANDBY (zero torque)
  damp                   -> DAMPING (controlled stop)
  ack                    acknowledge faults: FAULT -> STANDBY once they are gone
  mu MU_LF MU_RF MU_LH MU_RH
                         friction per foot used by the controller (servo accepts [0, 2])
  controller NAME        pid | noslip | stage1 | two_stage
  gains KP_SCALE KD_SCALE
                         multipliers of the configured feedback gains (servo accepts [0.1, 2])
  velocity VX VY WZ      the trot's base velocity: VX m/s forward, VY m/s to the left, WZ rad/s
                         yaw rate (counter-clockwise); the servo accepts |VX| <= 0.4, |VY| <= 0.2,
                         |WZ| <= 0.5 by default (commands.max_velocity) and ramps to it
                         (reference.trot.max_acceleration); "velocity 0 0 0" trots in place

options:
  --key FILE             the robot's key (default $HYQ_COMMAND_KEY, else /etc/hyq/command.key);
                         it must be readable by its owner alone (mode 0600 or 0400)
  --sender NAME          who signs (default USER@HOST); the servo keeps one sequence per sender
  --generate-key FILE    write a new random key to FILE (mode 0600; never overwrites) and exit
  --lcm-url URL          LCM URL (default udpm://239.255.76.67:7667?ttl=0)
  --channel NAME         command channel (default HYQ_COMMAND)
  --sequence N           sequence number, echoed in the servo's events (default: the time in µs,
                         so that it grows from one call to the next)
  -h, --help             this text
)";

}  // namespace

int main(int argc, char** argv) {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel = "HYQ_COMMAND";
  const long long now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                              std::chrono::system_clock::now().time_since_epoch())
                              .count();
  long long sequence = now_us;
  std::string key_file = hyq::servo::DefaultCommandKeyFile();
  std::string sender = hyq::servo::DefaultCommandSender();
  std::vector<std::string> args;
  hyq::cli::CommandLine cl(argc, argv, "hyq-command", kUsage);
  while (cl.Next()) {
    if (cl.Flag("--generate-key")) {
      const std::string path = cl.Value();
      return hyq::cli::Run(cl.tool(), [&] {
        hyq::servo::GenerateCommandKey(path);
        std::printf("hyq-command: wrote a new key to %s (mode 0600); give the servo the same file\n",
                    path.c_str());
        return 0;
      });
    } else if (cl.Flag("--key")) {
      key_file = cl.Value();
    } else if (cl.Flag("--sender")) {
      sender = cl.Text(1, hyq::servo::kMaxSenderBytes);
    } else if (cl.Flag("--lcm-url")) {
      url = cl.Value();
    } else if (cl.Flag("--channel")) {
      channel = cl.Value();
    } else if (cl.Flag("--sequence")) {
      sequence = cl.Integer(std::numeric_limits<long long>::min(),
                            std::numeric_limits<long long>::max(), "an integer");
    } else if (cl.IsOption()) {
      cl.Unknown();
    } else {
      args.push_back(cl.arg());
    }
  }
  if (args.empty())
    cl.Fail("expected a command (enable, disable, damp, ack, mu, controller, gains, velocity)");

  using K = hyq_lcm::lcmt_hyq_command;
  K msg{};
  msg.utime = now_us;
  msg.sequence = sequence;
  msg.kp_scale = msg.kd_scale = 1.0;
  const std::string_view cmd = args[0];
  const std::size_t nargs = args.size() - 1;
  const auto expect_args = [&](std::size_t n, const char* what) {
    if (nargs != n)
      cl.Fail(std::string(cmd) + ": expected " + what + ", found " + std::to_string(nargs) +
           " argument(s)");
  };
  if (cmd == "enable" || cmd == "disable" || cmd == "damp" || cmd == "ack") {
    expect_args(0, "no arguments");
    msg.kind = cmd == "enable" ? K::KIND_ENABLE
               : cmd == "disable" ? K::KIND_DISABLE
               : cmd == "damp" ? K::KIND_DAMP
                               : K::KIND_ACKNOWLEDGE;
  } else if (cmd == "mu") {
    expect_args(4, "4 friction coefficients (lf rf lh rh)");
    msg.kind = K::KIND_SET_MU;
    msg.num_feet = 4;
    for (std::size_t f = 0; f < 4; ++f)
      msg.mu.push_back(cl.NumberOf("mu[" + std::to_string(f) + "]", args[f + 1]));
  } else if (cmd == "controller") {
    expect_args(1, "a controller name (pid, noslip, stage1, two_stage, pd_gravity)");
    msg.kind = K::KIND_SET_CONTROLLER;
    msg.controller = args[1];
  } else if (cmd == "gains") {
    expect_args(2, "KP_SCALE KD_SCALE");
    msg.kind = K::KIND_SET_GAINS;
    msg.kp_scale = cl.NumberOf("KP_SCALE", args[1]);
    msg.kd_scale = cl.NumberOf("KD_SCALE", args[2]);
  } else if (cmd == "velocity") {
    expect_args(3, "VX VY WZ (m/s, m/s, rad/s)");
    msg.kind = K::KIND_SET_VELOCITY;
    for (std::size_t i = 0; i < 3; ++i) {
      const char* name = i == 0 ? "VX" : i == 1 ? "VY" : "WZ";
      msg.velocity[i] = cl.NumberOf(name, args[i + 1]);
    }
  } else {
    cl.Fail("unknown command '" + std::string(cmd) +
         "' (expected enable, disable, damp, ack, mu, controller, gains or velocity)");
  }

  // a key file that is missing or readable by others: exit 1
  return hyq::cli::Run(cl.tool(), [&] {
    const std::vector<std::uint8_t> signed_bytes =
        hyq::servo::SignCommand(hyq::servo::LoadCommandKey(key_file), sender, msg);
    lcm::LCM lcm(url);
    if (!lcm.good()) {
      std::fprintf(stderr, "hyq-command: cannot open LCM on '%s'\n", url.c_str());
      return 1;
    }
    if (lcm.publish(channel, signed_bytes.data(), static_cast<unsigned>(signed_bytes.size())) != 0) {
      std::fprintf(stderr, "hyq-command: publishing on '%s' failed\n", channel.c_str());
      return 1;
    }
    std::printf("hyq-command: sent %.*s (sequence %lld, signed by %s) on %s via %s\n",
                static_cast<int>(cmd.size()), cmd.data(), static_cast<long long>(sequence),
                sender.c_str(), channel.c_str(), url.c_str());
    return 0;
  });
}
