// The robot's side of tests/tools/teleop_test.sh: authenticates every datagram on HYQ_COMMAND
// with the robot's key (servo/command/command_auth.h, as the daemon's telemetry thread does)
// and writes one line per datagram to OUT_FILE:
//   ok KIND SEQUENCE VX VY WZ WALL_S        an authentic, fresh command
//   refused WHY                             anything else
// and publishes HYQ_BASE_STATE every 50 ms: the base turned 90° (yaw = π/2), moving at 0.123 m/s
// along world y, turning at 0.07 rad/s, i.e. 0.123 m/s forward in its heading frame.
//   teleop_listener KEY_FILE OUT_FILE          (until SIGTERM)
#include <poll.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "servo/command/command_auth.h"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

double WallS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

class Listener {
 public:
  Listener(const hyq::servo::CommandKey& key, std::FILE* out) : auth_(key, {}), out_(out) {}
  void OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
    hyq_lcm::lcmt_hyq_command msg;
    char why[160];
    const auto now_us = static_cast<std::int64_t>(WallS() * 1e6);
    if (auth_.Check(rbuf->data, rbuf->data_size, now_us, &msg, why, sizeof why) ==
        hyq::servo::AuthVerdict::kOk) {
      std::fprintf(out_, "ok %d %lld %.6f %.6f %.6f %.6f\n", msg.kind,
                   static_cast<long long>(msg.sequence), msg.velocity[0], msg.velocity[1],
                   msg.velocity[2], WallS());
    } else {
      std::fprintf(out_, "refused %s\n", why);
    }
    std::fflush(out_);
  }

 private:
  hyq::servo::CommandAuthenticator auth_;
  std::FILE* out_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: teleop_listener KEY_FILE OUT_FILE\n");
    return 2;
  }
  std::FILE* out = std::fopen(argv[2], "w");
  if (out == nullptr) return 1;
  lcm::LCM lcm;
  if (!lcm.good()) return 1;
  Listener listener(hyq::servo::LoadCommandKey(argv[1]), out);
  lcm.subscribe("HYQ_COMMAND", &Listener::OnCommand, &listener);
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGINT, OnSignal);
  hyq_lcm::lcmt_hyq_base_state state{};
  state.position_m[2] = 0.6;
  state.orientation_wxyz[0] = std::cos(M_PI / 4);
  state.orientation_wxyz[3] = std::sin(M_PI / 4);
  state.velocity_m_s[1] = 0.123;
  state.angular_velocity_rad_s[2] = 0.07;
  auto next = std::chrono::steady_clock::now();
  while (g_stop == 0) {
    if (std::chrono::steady_clock::now() >= next) {
      ++state.cycle;
      state.utime = static_cast<std::int64_t>(WallS() * 1e6);
      lcm.publish("HYQ_BASE_STATE", &state);
      next += std::chrono::milliseconds(50);
    }
    lcm.handleTimeout(10);
  }
  std::fclose(out);
  return 0;
}
