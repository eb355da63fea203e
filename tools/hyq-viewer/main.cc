// hyq-viewer: the robot's telemetry in a browser. A read-only bridge from LCM (or an
// lcm-logger file) to a WebSocket: it serves one page (three.js + uPlot, bundled at build time)
// and streams the states decimated to the page's rate, every event, and hyq-sim's truth.
// docs/viewer.md describes the page and this command line.
#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <lcm/lcm-cpp.hpp>

#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"
#include "tools/hyq-viewer/log_player.h"
#include "tools/hyq-viewer/telemetry_json.h"
#include "tools/hyq-viewer/web_server.h"

namespace {

namespace asio = boost::asio;
constexpr const char* kTool = "hyq-viewer";
constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

struct Options {
  std::string bind = "127.0.0.1";
  int port = 8087;
  std::string lcm_url = kDefaultLcmUrl;
  std::string lcm_netns;  // empty: this process's network namespace
  std::string log;
  bool paused = false;
  double rate_hz = 30.0;
  std::string web_dir = hyq::cli::DefaultViewerWebDir();
  std::string urdf = hyq::cli::DefaultUrdf();
  bool quiet = false;
};

std::string Help() {
  return std::string() +
    "usage: hyq-viewer [--bind ADDR] [--port N] [--lcm-url URL [--lcm-netns PATH] | --log FILE [--paused]]\n"
    "                  [--rate-hz HZ] [--web-dir DIR] [--urdf FILE] [--quiet]\n"
    "HyQ's telemetry in a browser, read-only: serves a page (3D robot, contacts, friction\n"
    "pyramids, slips, mode and events, plots) on http://ADDR:N/ and streams HYQ_JOINT_STATE,\n"
    "HYQ_BASE_STATE, HYQ_CONTACT, HYQ_FRICTION, HYQ_TIMING, HYQ_JOINT_TORQUE (latest, at HZ),\n"
    "HYQ_EVENT (all) and HYQ_SIM_TRUTH (hyq-sim --lcm-truth) to it over a WebSocket.\n"
    "The page cannot command the robot. docs/viewer.md.\n"
    "  --bind ADDR     address to listen on (default 127.0.0.1: this machine only)\n"
    "  --port N        TCP port, 0..65535 (default 8087; 0: any free port)\n"
    "  --lcm-url URL   LCM to subscribe to (default " + kDefaultLcmUrl + ")\n"
    "  --lcm-netns PATH  subscribe inside that network namespace (e.g. /proc/PID/ns/net of\n"
    "                  scripts/hil.sh's hyq-sim) while serving the page in this one; root\n"
    "  --log FILE      play an lcm-logger file instead (pause, resume, seek, speed on the page)\n"
    "  --paused        with --log: start paused at the beginning\n"
    "  --rate-hz HZ    frames per second sent to the page, 1..120 (default 30)\n"
    "  --web-dir DIR   the bundled page (default <prefix>/share/hyq/viewer, or the build tree's)\n"
    "  --urdf FILE     robot model drawn by the page (default @config@/robots/hyq.urdf)\n"
    "  --quiet         no status line on stderr\n";
}

Options Parse(int argc, char** argv) {
  Options o;
  bool lcm_url_given = false;
  hyq::cli::CommandLine cl(argc, argv, kTool, hyq::cli::WithPaths(Help()));
  while (cl.Next()) {
    if (cl.Flag("--bind")) {
      o.bind = cl.Value();
      boost::system::error_code ec;
      (void)asio::ip::make_address(o.bind, ec);
      if (ec) cl.BadValue("an IPv4 or IPv6 address (127.0.0.1, 0.0.0.0, ::1)", o.bind);
    } else if (cl.Flag("--port")) {
      o.port = static_cast<int>(cl.Integer(0, 65535, "a port number 0..65535"));
    } else if (cl.Flag("--lcm-url")) {
      o.lcm_url = cl.Value();
      lcm_url_given = true;
      if (o.lcm_url.empty()) cl.BadValue("an LCM URL (udpm://239.255.76.67:7667?ttl=0)", o.lcm_url);
    } else if (cl.Flag("--lcm-netns")) {
      o.lcm_netns = cl.Value();
      if (!std::filesystem::exists(o.lcm_netns))
        cl.BadValue("a network namespace file (/proc/PID/ns/net)", o.lcm_netns);
    } else if (cl.Flag("--log")) {
      o.log = cl.Value();
      if (!std::filesystem::is_regular_file(o.log)) cl.BadValue("a readable lcm-logger file", o.log);
    } else if (cl.Flag("--paused")) {
      o.paused = true;
    } else if (cl.Flag("--rate-hz")) {
      o.rate_hz = cl.Number(1, 120, "frames per second 1..120");
    } else if (cl.Flag("--web-dir")) {
      o.web_dir = cl.Value();
      if (!std::filesystem::is_directory(o.web_dir))
        cl.BadValue("a directory holding index.html", o.web_dir);
    } else if (cl.Flag("--urdf")) {
      o.urdf = cl.Value();
      if (!std::filesystem::is_regular_file(o.urdf)) cl.BadValue("a readable URDF file", o.urdf);
    } else if (cl.Flag("--quiet")) {
      o.quiet = true;
    } else {
      cl.Unknown();
    }
  }
  if (lcm_url_given && !o.log.empty())
    cl.Bad("--lcm-url", "either --lcm-url or --log, not both", o.lcm_url);
  if (!o.lcm_netns.empty() && !o.log.empty())
    cl.Bad("--lcm-netns", "live LCM, not --log", o.lcm_netns);
  if (o.paused && o.log.empty()) cl.Bad("--paused", "--log FILE with it", "--paused alone");
  return o;
}

double NowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Live LCM into the model, on its own thread.
class LcmSource {
 public:
  LcmSource(const std::string& url, hyq::viewer::TelemetryModel* model, std::mutex* mutex)
      : lcm_(url), model_(model), mutex_(mutex) {
    if (!lcm_.good()) throw std::runtime_error("--lcm-url: cannot open LCM on '" + url + "'");
    for (const char* channel : hyq::viewer::kChannels) lcm_.subscribe(channel, &LcmSource::On, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(100);
    });
  }
  ~LcmSource() {
    stop_ = true;
    thread_.join();
  }

 private:
  void On(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const std::span<const std::uint8_t> data(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size);
    std::lock_guard<std::mutex> lock(*mutex_);
    model_->Feed(channel, data);
  }

  lcm::LCM lcm_;
  hyq::viewer::TelemetryModel* model_;
  std::mutex* mutex_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// Moves this thread (and the threads it starts later) into the network namespace at `path`.
void EnterNetns(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("--lcm-netns: cannot open '" + path + "': " + std::strerror(errno));
  const int rc = setns(fd, CLONE_NEWNET);
  const int err = errno;
  close(fd);
  if (rc != 0)
    throw std::runtime_error("--lcm-netns: cannot enter '" + path + "': " + std::strerror(err) +
                             " (needs root or CAP_SYS_ADMIN; expected a network namespace file)");
}

int Run(const Options& o) {
  using namespace hyq::viewer;
  TelemetryModel model;
  std::mutex mutex;
  std::unique_ptr<LogPlayer> player;
  if (!o.log.empty()) {
    player = std::make_unique<LogPlayer>(o.log);
    if (o.paused) player->StartPaused();
  }

  asio::io_context io;
  const std::filesystem::path web(o.web_dir);
  std::map<std::string, ServedFile> files = {
      {"/", {(web / "index.html").string(), "text/html; charset=utf-8"}},
      {"/index.html", {(web / "index.html").string(), "text/html; charset=utf-8"}},
      {"/app.js", {(web / "app.js").string(), "text/javascript; charset=utf-8"}},
      {"/app.css", {(web / "app.css").string(), "text/css; charset=utf-8"}},
      {"/hyq.urdf", {o.urdf, "application/xml"}},
  };
  // the page may send playback controls in log mode; everything else it sends is ignored
  std::uint64_t ignored = 0;
  auto on_text = [&](const std::string& text) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!player || !player->Control(text, NowS(), &model)) ++ignored;
  };
  const asio::ip::tcp::endpoint endpoint(asio::ip::make_address(o.bind), static_cast<std::uint16_t>(o.port));
  WebServer server(io, endpoint, files, on_text);

  // the page's socket is bound above, in this namespace; LCM's sockets (and the LCM thread) are
  // made after this, in the HIL run's namespace
  if (!o.lcm_netns.empty()) EnterNetns(o.lcm_netns);
  std::unique_ptr<LcmSource> lcm;
  if (!player) lcm = std::make_unique<LcmSource>(o.lcm_url, &model, &mutex);
  std::printf("%s: http://%s:%u/ (%s)\n", kTool,
              endpoint.address().is_v6() ? ("[" + o.bind + "]").c_str() : o.bind.c_str(),
              static_cast<unsigned>(server.port()),
              player ? ("log " + o.log + ", " + std::to_string(player->size()) + " messages").c_str()
                     : ("live, " + o.lcm_url + (o.lcm_netns.empty() ? "" : " in " + o.lcm_netns)).c_str());
  std::fflush(stdout);

  asio::signal_set signals(io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code&, int) { io.stop(); });

  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / o.rate_hz));
  asio::steady_timer timer(io);
  auto next = std::chrono::steady_clock::now();
  double next_status_s = NowS() + 5.0;
  std::function<void()> tick = [&] {
    next += period;
    std::string text;
    {
      std::lock_guard<std::mutex> lock(mutex);
      const double now_s = NowS();
      if (player) player->Advance(now_s, &model);
      nlohmann::json frame = model.TakeFrame();
      frame["source"] = player ? "log" : "live";
      frame["rate_hz"] = o.rate_hz;
      frame["controls_ignored"] = ignored;
      if (player) frame["playback"] = player->Status(now_s);
      text = frame.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      if (!o.quiet && now_s >= next_status_s) {
        next_status_s = now_s + 5.0;
        std::fprintf(stderr, "%s: %zu browser(s), %llu messages, %llu undecodable\n", kTool, server.clients(),
                     static_cast<unsigned long long>(model.messages()),
                     static_cast<unsigned long long>(model.undecodable()));
      }
    }
    server.Broadcast(text);
    if (std::chrono::steady_clock::now() > next + 10 * period) next = std::chrono::steady_clock::now();
    timer.expires_at(next);
    timer.async_wait([&](const boost::system::error_code& ec) {
      if (!ec) tick();
    });
  };
  tick();
  io.run();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Parse(argc, argv);
  return hyq::cli::Run(kTool, [&] { return Run(o); });
}
