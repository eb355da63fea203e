// hyq-teleop: steers the trot from a terminal (docs/steering.md). Keys change the commanded base
// velocity in steps within limits; the changes are signed set-velocity commands
// (lcmt_hyq_command KIND_SET_VELOCITY in an lcmt_hyq_signed_command, servo/command/command_auth.h)
// sent at a bounded rate; the screen shows the commanded velocity and the estimated one from
// HYQ_BASE_STATE. The terminal is in raw mode (termios) while it runs and restored on every exit.
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "hyq_lcm/lcmt_hyq_base_state.hpp"
#include "hyq_lcm/lcmt_hyq_command.hpp"
#include "servo/command/command_auth.h"
#include "tools/cli/command_line.h"

namespace {

constexpr const char* kUsage = R"(usage: hyq-teleop [--key FILE] [--lcm-url URL] [options]

Steers the HyQ trot from this terminal: each key changes the commanded base velocity by one step
within the limits, and the change is sent to the servo's command channel as a signed set-velocity
command (what "hyq-command velocity VX VY WZ" sends; docs/steering.md), at most --rate times a
second, the current command repeated once a second. The screen shows the commanded velocity and
the servo's estimated one (HYQ_BASE_STATE, in the heading frame). The servo must run the trot
reference with its command channel enabled; it refuses values beyond its commands.max_velocity.

keys:
  w / Up arrow           faster forward (vx + step)
  s / Down arrow         slower / backward (vx - step)
  a / d                  sideways to the left / right (vy + step / vy - step)
  Left / Right arrow     turn left / right (wz + step / wz - step)
  space                  stop walking: zero velocity (the trot steps in place)
  q / Ctrl-C             quit (the terminal is restored; nothing more is sent)

options:
  --key FILE             the robot's key (default $HYQ_COMMAND_KEY, else /etc/hyq/command.key;
                         mode 0600 or 0400)
  --lcm-url URL          LCM URL (default udpm://239.255.76.67:7667?ttl=0)
  --sender NAME          who signs (default USER@HOST)
  --channel NAME         command channel (default HYQ_COMMAND)
  --state-channel NAME   estimated base state (default HYQ_BASE_STATE)
  --max VX,VY,WZ         limits, m/s, m/s, rad/s (default 0.4,0.2,0.5: the servo's defaults)
  --step VX,VY,WZ        one key's change (default 0.05,0.05,0.1)
  --rate HZ              commands sent at most this often (default 4; 0.2..20; keep it below
                         the servo's commands.max_rate_hz, which refuses faster ones)
  -h, --help             this text
)";

using Clock = std::chrono::steady_clock;
using Vec3 = std::array<double, 3>;

// The flag's value as three numbers VX,VY,WZ, each in [lo, hi].
Vec3 Triple(hyq::cli::CommandLine& cl, double lo, double hi) {
  const std::string text = cl.Value();
  const std::vector<std::string> parts = hyq::cli::Split(text, ',');
  char expected[80];
  std::snprintf(expected, sizeof expected, "3 numbers VX,VY,WZ in [%g, %g]", lo, hi);
  Vec3 v{};
  if (parts.size() != 3) cl.BadValue(expected, text);
  for (std::size_t i = 0; i < 3; ++i) {
    const std::optional<double> x = hyq::cli::ParseNumber(parts[i]);
    if (!x || *x < lo || *x > hi) cl.BadValue(expected, text);
    v[i] = *x;
  }
  return v;
}

// raw mode while alive; restored by Restore() on every way out
termios g_saved;
bool g_raw = false;
volatile std::sig_atomic_t g_stop = 0;

void Restore() {
  if (!g_raw) return;
  const char leave[] = "\x1b[?25h\x1b[?1049l";  // cursor back, main screen back
  (void)!write(STDOUT_FILENO, leave, sizeof leave - 1);
  tcsetattr(STDIN_FILENO, TCSAFLUSH, &g_saved);
  g_raw = false;
}

void OnSignal(int) { g_stop = 1; }

// A terminal that is missing or refuses raw mode is a usage error (exit 2), as before any key is read.
void EnterRaw(const hyq::cli::CommandLine& cl) {
  if (!isatty(STDIN_FILENO)) cl.Fail("stdin: expected a terminal, found none (run it in a terminal)");
  if (tcgetattr(STDIN_FILENO, &g_saved) != 0) cl.Fail(std::string("tcgetattr: ") + std::strerror(errno));
  termios raw = g_saved;
  raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO | ISIG | IEXTEN);
  raw.c_iflag &= ~static_cast<tcflag_t>(IXON | ICRNL);
  raw.c_cc[VMIN] = 0;
  raw.c_cc[VTIME] = 0;
  if (tcsetattr(STDIN_FILENO, TCSAFLUSH, &raw) != 0) cl.Fail(std::string("tcsetattr: ") + std::strerror(errno));
  g_raw = true;
  std::atexit(Restore);
  const char enter[] = "\x1b[?1049h\x1b[?25l";  // alternate screen, no cursor
  (void)!write(STDOUT_FILENO, enter, sizeof enter - 1);
}

enum class Key { kNone, kForward, kBack, kLeft, kRight, kTurnLeft, kTurnRight, kStop, kQuit };

// one key from the bytes read (arrows are ESC [ A..D or ESC O A..D); *used: bytes consumed, 0
// when an escape sequence is still arriving
Key NextKey(std::string_view in, std::size_t* used) {
  *used = 1;
  if (in[0] == '\x1b') {
    if (in.size() < 3) {
      *used = 0;
      return Key::kNone;
    }
    if (in[1] != '[' && in[1] != 'O') return Key::kNone;  // a lone ESC
    *used = 3;
    switch (in[2]) {
      case 'A': return Key::kForward;
      case 'B': return Key::kBack;
      case 'C': return Key::kTurnRight;
      case 'D': return Key::kTurnLeft;
      default: return Key::kNone;
    }
  }
  switch (in[0]) {
    case 'w': case 'W': return Key::kForward;
    case 's': case 'S': return Key::kBack;
    case 'a': case 'A': return Key::kLeft;
    case 'd': case 'D': return Key::kRight;
    case ' ': return Key::kStop;
    case 'q': case 'Q': case '\x03': return Key::kQuit;
    default: return Key::kNone;
  }
}

// the velocity after a key: one step on one axis, clamped to the limits (zero stays exactly zero)
Vec3 Apply(Key k, Vec3 v, const Vec3& step, const Vec3& max) {
  const auto add = [&](std::size_t i, double sign) {
    v[i] = std::clamp(v[i] + sign * step[i], -max[i], max[i]);
    if (std::abs(v[i]) < 1e-9) v[i] = 0.0;
  };
  switch (k) {
    case Key::kForward: add(0, +1); break;
    case Key::kBack: add(0, -1); break;
    case Key::kLeft: add(1, +1); break;
    case Key::kRight: add(1, -1); break;
    case Key::kTurnLeft: add(2, +1); break;
    case Key::kTurnRight: add(2, -1); break;
    case Key::kStop: v = {0.0, 0.0, 0.0}; break;
    default: break;
  }
  return v;
}

struct Estimate {
  Vec3 v_H{};  // vx, vy (heading frame) m/s, wz rad/s
  Clock::time_point at{};
  bool any = false;
};

class StateListener {
 public:
  explicit StateListener(Estimate* e) : e_(e) {}
  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
    hyq_lcm::lcmt_hyq_base_state m;
    if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
    const auto& q = m.orientation_wxyz;
    const double yaw = std::atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
    const double c = std::cos(yaw), s = std::sin(yaw);
    const auto& v = m.velocity_m_s;
    e_->v_H = {c * v[0] + s * v[1], -s * v[0] + c * v[1], m.angular_velocity_rad_s[2]};
    e_->at = Clock::now();
    e_->any = true;
  }

 private:
  Estimate* e_;
};

}  // namespace

int main(int argc, char** argv) {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel = "HYQ_COMMAND", state_channel = "HYQ_BASE_STATE";
  std::string key_file = hyq::servo::DefaultCommandKeyFile();
  std::string sender = hyq::servo::DefaultCommandSender();
  Vec3 max{0.4, 0.2, 0.5}, step{0.05, 0.05, 0.1};
  double rate_hz = 4.0;
  hyq::cli::CommandLine cl(argc, argv, "hyq-teleop", kUsage);
  while (cl.Next()) {
    if (cl.Flag("--key")) {
      key_file = cl.Value();
    } else if (cl.Flag("--lcm-url")) {
      url = cl.Value();
    } else if (cl.Flag("--sender")) {
      sender = cl.Text(1, hyq::servo::kMaxSenderBytes);
    } else if (cl.Flag("--channel")) {
      channel = cl.Value();
    } else if (cl.Flag("--state-channel")) {
      state_channel = cl.Value();
    } else if (cl.Flag("--max")) {
      max = Triple(cl, 0.0, 2.0);
    } else if (cl.Flag("--step")) {
      step = Triple(cl, 1e-3, 1.0);
    } else if (cl.Flag("--rate")) {
      rate_hz = cl.Number(0.2, 20.0, "a number in [0.2, 20] Hz");
    } else {
      cl.Unknown();
    }
  }

  hyq::servo::CommandKey key;
  if (const int status = hyq::cli::Run(cl.tool(), [&] {
        key = hyq::servo::LoadCommandKey(key_file);
        return 0;
      });
      status != 0)
    return status;
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "hyq-teleop: cannot open LCM on '%s'\n", url.c_str());
    return 1;
  }
  Estimate estimate;
  StateListener listener(&estimate);
  lcm.subscribe(state_channel, &StateListener::OnState, &listener);

  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  EnterRaw(cl);

  Vec3 commanded{}, sent{};
  bool any_sent = false;
  long long sequence = 0;
  unsigned long sent_count = 0, send_failures = 0;
  Clock::time_point last_send{};
  const auto min_gap = std::chrono::duration<double>(1.0 / rate_hz);
  std::string note = "no command sent yet";
  std::string pending_bytes;

  const auto send = [&](const Vec3& v) {
    const auto wall_us = std::chrono::duration_cast<std::chrono::microseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
    sequence = std::max<long long>(wall_us, sequence + 1);
    hyq_lcm::lcmt_hyq_command msg{};
    msg.utime = wall_us;
    msg.sequence = sequence;
    msg.kind = hyq_lcm::lcmt_hyq_command::KIND_SET_VELOCITY;
    msg.kp_scale = msg.kd_scale = 1.0;
    for (std::size_t i = 0; i < 3; ++i) msg.velocity[i] = v[i];
    const std::vector<std::uint8_t> bytes = hyq::servo::SignCommand(key, sender, msg);
    if (lcm.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())) == 0) {
      ++sent_count;
      sent = v;
      any_sent = true;
      char line[128];
      std::snprintf(line, sizeof line, "sent %+.2f %+.2f %+.2f (sequence %lld), %lu so far", v[0],
                    v[1], v[2], sequence, sent_count);
      note = line;
    } else {
      ++send_failures;
      note = "publishing on " + channel + " failed (" + std::to_string(send_failures) + " so far)";
    }
    last_send = Clock::now();
  };

  const auto draw = [&] {
    std::string s = "\x1b[H\x1b[2J";
    char line[256];
    s += "hyq-teleop: steering the trot on " + channel + " (signed by " + sender + ")\r\n\r\n";
    std::snprintf(line, sizeof line, "commanded  vx %+.2f m/s  vy %+.2f m/s  wz %+.2f rad/s\r\n",
                  commanded[0], commanded[1], commanded[2]);
    s += line;
    if (estimate.any) {
      const double age = std::chrono::duration<double>(Clock::now() - estimate.at).count();
      std::snprintf(line, sizeof line,
                    "estimated  vx %+.2f m/s  vy %+.2f m/s  wz %+.2f rad/s  (%s, %.1f s ago)\r\n",
                    estimate.v_H[0], estimate.v_H[1], estimate.v_H[2], state_channel.c_str(), age);
    } else {
      std::snprintf(line, sizeof line, "estimated  none yet (no %s message)\r\n", state_channel.c_str());
    }
    s += line;
    std::snprintf(line, sizeof line, "limits     vx %.2f  vy %.2f  wz %.2f; step %.2f %.2f %.2f; at most %g commands/s\r\n",
                  max[0], max[1], max[2], step[0], step[1], step[2], rate_hz);
    s += line;
    s += "last       " + note + "\r\n\r\n";
    s += "w/s or Up/Down: forward/back   a/d: left/right   Left/Right: turn   space: stop   q: quit\r\n";
    (void)!write(STDOUT_FILENO, s.data(), s.size());
  };

  draw();
  Clock::time_point next_draw = Clock::now();
  bool quit = false;
  while (!quit && g_stop == 0) {
    pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {lcm.getFileno(), POLLIN, 0}};
    (void)poll(fds, 2, 50);
    if ((fds[1].revents & POLLIN) != 0) lcm.handleTimeout(0);
    bool changed = false;
    if ((fds[0].revents & (POLLIN | POLLHUP)) != 0) {
      char buf[64];
      const ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
      if (n == 0 && (fds[0].revents & POLLHUP) != 0) break;  // the terminal went away
      if (n > 0) pending_bytes.append(buf, static_cast<std::size_t>(n));
      while (!pending_bytes.empty()) {
        std::size_t used = 0;
        const Key k = NextKey(pending_bytes, &used);
        if (used == 0) break;  // the rest of an escape sequence comes with the next read
        pending_bytes.erase(0, used);
        if (k == Key::kQuit) {
          quit = true;
          break;
        }
        const Vec3 v = Apply(k, commanded, step, max);
        changed = changed || v != commanded;
        commanded = v;
      }
    }
    const Clock::time_point now = Clock::now();
    const bool due = now - last_send >= min_gap;
    if (!quit && due && ((any_sent && commanded != sent) || (!any_sent && commanded != Vec3{}) ||
                         (any_sent && now - last_send >= std::chrono::seconds(1))))
      send(commanded);
    if (changed || now >= next_draw) {
      draw();
      next_draw = now + std::chrono::milliseconds(100);
    }
  }
  Restore();
  std::printf("hyq-teleop: sent %lu set-velocity command(s), the last %+.2f %+.2f %+.2f\n",
              sent_count, sent[0], sent[1], sent[2]);
  return 0;
}
