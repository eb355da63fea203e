// hyq-servod: the servo daemon (docs/servo.md). Loads and validates the configuration, brings
// every device to OP through the HAL, then runs the servo loop on a real-time thread until
// SIGINT / SIGTERM (or the configured duration): controlled stop, devices back to PRE-OP,
// telemetry flushed, a summary printed.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/servo_config_loader.h"
#include "drivers/channel_factory.h"
#include "dynamics/urdf_loader.h"
#include "hal/clock.h"
#include "hal/hal.h"
#include "servo/command/command_auth.h"
#include "servo/runtime/host_check.h"
#include "servo/runtime/realtime_thread.h"
#include "servo/runtime/servo_loop.h"
#include "servo/runtime/servo_runner.h"
#include "servo/telemetry/telemetry.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"

namespace {

using hyq::servo::ServoMode;

struct Options {
  std::string config = hyq::cli::DefaultServoConfig();
  bool check = false, check_host = false;
  double check_host_s = 2.0;
  bool quiet = false;
  bool exit_on_fault = false;
  std::map<std::string, std::string> interfaces;
  std::optional<std::string> clock, controller, reference, lcm_url, command_key;
  std::optional<double> duration;
  std::vector<hyq::servo::TimedVelocity> steer;
  std::optional<std::array<double, 4>> mu;
  bool auto_enable = false, no_telemetry = false, commands = false;
  std::string summary;
  double overrun_at_s = -1.0, overrun_us = 0.0;
  int overrun_cycles = 0;
};

constexpr const char* kHelp = R"(usage: hyq-servod [--config FILE] [--check | --check-host] [options]
The HyQ servo daemon: every period it reads the joints and the IMU over CAN (HAL), estimates
the base state, follows the reference with the configured controller (two-stage contact ID by
default), checks everything (safety) and writes the joint torques; LCM telemetry on the side.
  --config FILE          servo configuration (default @config@/hyq_servo.yaml)
  --check                validate the configuration (and the HAL file and URDF it names), exit
  --check-host           whether this computer can hold the real-time loop as configured: the
                         kernel's preemption, the servo CPU's isolation, interrupts, governor
                         and idle states, the memlock and rtprio limits, RT throttling, and the
                         wake-up latency measured on the servo CPU; each item with its fix
                         (docs/realtime_host.md). Exit 0, or 4 when realtime.require_rt_host is
                         true and an item is not ok
  --check-host-seconds S the wake-up measurement's length (default 2; 0: none)
  --interface BUS=SPEC   open bus BUS on SPEC (socketcan:can0, udp::43101, ...) instead of the
                         configured interface
  --clock realtime|lockstep
                         absolute-time periods, or virtual time waiting for the devices' answers
                         after each SYNC (hardware-in-the-loop with hyq-sim --mode lockstep)
  --controller KIND      pid, noslip, stage1, two_stage or pd_gravity
  --reference KIND       stand, trot or figure_eight
  --mu M | --mu A,B,C,D  friction coefficient the controller assumes (all feet / lf,rf,lh,rh)
  --duration S           stop after S seconds in ACTIVE (0: run until SIGINT/SIGTERM)
  --steer T:VX,VY,WZ     steer the trot at T s of the reference's time (after the stand-up) to
                         VX, VY m/s and WZ rad/s, as a set-velocity command would (repeatable,
                         at most 8, in increasing T; docs/steering.md)
  --auto-enable          go from STANDBY to ACTIVE without an operator command
  --commands             open the LCM command channel (off unless configured or given); it
                         takes only commands signed with the robot's key (docs/security.md)
  --command-key FILE     the key file (default commands.key_file, /etc/hyq/command.key)
  --exit-on-fault        stop (devices to PRE-OP, exit 3) once in FAULT instead of waiting for
                         an acknowledgement
  --no-telemetry         no LCM at all
  --lcm-url URL          telemetry URL (default from the configuration)
  --summary FILE         write the run's summary as JSON
  --inject-overrun AT:US[:N]
                         fault injection: N cycles (default 10) overrun by US microseconds,
                         AT seconds after ACTIVE
  --quiet                no progress line
  -h, --help             this text
Exit status: 0 after a controlled stop, 1 configuration or start-up error, 2 bad command line,
3 stopped in FAULT (--exit-on-fault), 4 a host not fit for real time (--check-host with
realtime.require_rt_host).
)";

Options Parse(hyq::cli::CommandLine& cl) {
  Options o;
  while (cl.Next()) {
    if (cl.Flag("--config")) o.config = cl.Value();
    else if (cl.Flag("--check")) o.check = true;
    else if (cl.Flag("--check-host")) o.check_host = true;
    else if (cl.Flag("--check-host-seconds")) o.check_host_s = cl.Number(0.0, 600.0);
    else if (cl.Flag("--quiet")) o.quiet = true;
    else if (cl.Flag("--auto-enable")) o.auto_enable = true;
    else if (cl.Flag("--commands")) o.commands = true;
    else if (cl.Flag("--command-key")) o.command_key = cl.Value();
    else if (cl.Flag("--exit-on-fault")) o.exit_on_fault = true;
    else if (cl.Flag("--no-telemetry")) o.no_telemetry = true;
    else if (cl.Flag("--lcm-url")) o.lcm_url = cl.Value();
    else if (cl.Flag("--summary")) o.summary = cl.Value();
    else if (cl.Flag("--interface")) {
      auto [bus, spec] = cl.KeyValue("BUS=SPEC");
      o.interfaces[std::move(bus)] = std::move(spec);
    } else if (cl.Flag("--clock")) {
      o.clock = cl.Value();
      if (*o.clock != "realtime" && *o.clock != "lockstep")
        cl.BadValue("realtime or lockstep", *o.clock);
    } else if (cl.Flag("--controller")) {
      o.controller = cl.Value();
      if (!hyq::servo::ParseControllerKind(*o.controller))
        cl.BadValue("pid, noslip, stage1, two_stage or pd_gravity", *o.controller);
    } else if (cl.Flag("--reference")) {
      o.reference = cl.Value();
      if (*o.reference != "stand" && *o.reference != "trot" && *o.reference != "figure_eight")
        cl.BadValue("stand, trot or figure_eight", *o.reference);
    } else if (cl.Flag("--duration")) {
      o.duration = cl.Number(0.0, 1e7);
    } else if (cl.Flag("--steer")) {
      const std::string v = cl.Value();
      const std::vector<std::string> tv = hyq::cli::Split(v, ':');
      if (tv.size() != 2) cl.BadValue("T:VX,VY,WZ (e.g. 3:0.3,0,0.2)", v);
      const std::vector<std::string> vel = hyq::cli::Split(tv[1], ',');
      if (vel.size() != 3) cl.BadValue("T:VX,VY,WZ with three velocities", v);
      hyq::servo::TimedVelocity s{cl.NumberOf("--steer", tv[0], 0.0, 1e7),
                                  cl.NumberOf("--steer", vel[0], -10.0, 10.0),
                                  cl.NumberOf("--steer", vel[1], -10.0, 10.0),
                                  cl.NumberOf("--steer", vel[2], -10.0, 10.0)};
      if (o.steer.size() >= hyq::servo::kMaxTimedVelocities)
        cl.BadValue("at most 8 --steer commands", v);
      if (!o.steer.empty() && s.t_s < o.steer.back().t_s)
        cl.BadValue("a time no earlier than the previous --steer's", v);
      o.steer.push_back(s);
    } else if (cl.Flag("--mu")) {
      const std::string v = cl.Value();
      const std::vector<std::string> parts = hyq::cli::Split(v, ',');
      if (parts.size() != 1 && parts.size() != 4)
        cl.BadValue("one number or four (lf,rf,lh,rh)", v);
      std::array<double, 4> mu{};
      for (std::size_t f = 0; f < 4; ++f)
        mu[f] = cl.NumberOf("--mu", parts[parts.size() == 1 ? 0 : f], 0.0, 2.0);
      o.mu = mu;
    } else if (cl.Flag("--inject-overrun")) {
      const std::string v = cl.Value();
      const std::vector<std::string> parts = hyq::cli::Split(v, ':');
      if (parts.size() != 2 && parts.size() != 3) cl.BadValue("AT:US[:N]", v);
      o.overrun_at_s = cl.NumberOf("--inject-overrun", parts[0], 0.0, 1e6);
      o.overrun_us = cl.NumberOf("--inject-overrun", parts[1], 0.0, 1e6);
      o.overrun_cycles =
          parts.size() == 2 ? 10
                            : static_cast<int>(cl.NumberOf("--inject-overrun", parts[2], 1, 1e6));
    } else {
      cl.Unknown();
    }
  }
  return o;
}

// Applies the command-line overrides; a bus name the configuration lacks is a usage error, the
// rest is validated as the file is (ValidateServoConfig throws ConfigError).
void Override(const hyq::cli::CommandLine& cl, const Options& o, hyq::servo::ServoConfig& c) {
  for (const auto& [bus, spec] : o.interfaces) {
    bool found = false;
    for (auto& b : c.hal.buses)
      if (b.name == bus) {
        b.interface = spec;
        found = true;
      }
    if (!found) cl.Bad("--interface", "a bus name of " + c.hal_file, bus);
  }
  if (o.clock) c.clock = *o.clock == "lockstep" ? hyq::servo::ClockMode::kLockstep
                                                 : hyq::servo::ClockMode::kRealtime;
  if (o.controller) c.controller.kind = *hyq::servo::ParseControllerKind(*o.controller);
  if (o.reference)
    c.reference = *o.reference == "trot"           ? hyq::servo::Reference::Kind::kTrot
                  : *o.reference == "figure_eight" ? hyq::servo::Reference::Kind::kFigureEight
                                                   : hyq::servo::Reference::Kind::kStand;
  if (o.duration) c.duration_s = *o.duration;
  for (std::size_t i = 0; i < o.steer.size(); ++i) c.steer[i] = o.steer[i];
  if (!o.steer.empty()) c.steer_count = o.steer.size();
  if (o.mu) c.mu = *o.mu;
  if (o.auto_enable) c.auto_enable = true;
  if (o.commands) c.commands.enabled = true;
  if (o.command_key) c.commands.key_file = *o.command_key;
  if (o.no_telemetry) c.telemetry.enabled = false;
  if (o.lcm_url) c.telemetry.lcm_url = *o.lcm_url;
  hyq::config::ValidateServoConfig(c);
}

double Us(std::int64_t ns) { return 1e-3 * static_cast<double>(ns); }

nlohmann::json Summary(const hyq::servo::ServoLoop& loop, const hyq::servo::ServoConfig& c,
                       double wall_s) {
  const auto& s = loop.stats();
  nlohmann::json j;
  j["controller"] = hyq::servo::ToString(c.controller.kind);
  j["clock"] = hyq::servo::ToString(c.clock);
  j["final_mode"] = hyq::servo::ToString(loop.mode());
  j["cycles"] = s.cycles;
  j["active_s"] = static_cast<double>(s.active_cycles) * c.period_s();
  // ACTIVE = stand-up + the reference + sit-down (docs/servo.md)
  j["stand_up_s"] = c.stand_up_s;
  j["sit_down_s"] = c.sit_down_s;
  j["wall_s"] = wall_s;
  const double n = static_cast<double>(std::max<std::uint64_t>(s.active_cycles, 1));
  j["tracking_error_mean_rad"] = s.tracking_error_sum_rad / n;
  j["tracking_error_max_rad"] = s.tracking_error_max_rad;
  j["joint_speed_max_rad_s"] = s.joint_speed_max_rad_s;
  const int jmax = s.joint_speed_max_joint;
  j["joint_speed_max_joint"] =
      jmax < 0 ? std::string()
               : std::string(hyq::dynamics::kLegNames[static_cast<std::size_t>(jmax / 3)]) + "_" +
                     hyq::dynamics::kLegJointNames[static_cast<std::size_t>(jmax % 3)];
  j["joint_speed_max_active_s"] = s.joint_speed_max_at_s;
  j["qp_time_mean_us"] = s.qp_time_sum_us / n;
  j["qp_time_max_us"] = s.qp_time_max_us;
  j["controller_fallbacks"] = s.controller_fallbacks;
  j["controller_fallbacks_deadline"] = s.controller_fallbacks_deadline;
  j["controller_fallbacks_deadline_stalled"] = s.controller_fallbacks_deadline_stalled;
  auto hist = [](const hyq::hal::LatencyHistogram& h) {
    return nlohmann::json{{"count", h.count()},         {"mean_us", 1e-3 * h.mean_ns()},
                          {"p50_us", Us(h.Percentile(0.5))}, {"p99_us", Us(h.Percentile(0.99))},
                          {"p999_us", Us(h.Percentile(0.999))}, {"max_us", Us(h.max_ns())}};
  };
  j["cycle_time"] = hist(s.cycle);
  j["control_time"] = hist(s.control);
  j["wakeup_latency"] = hist(s.wakeup);
  j["deadline_misses"] = s.deadline_misses;
  j["max_consecutive_misses"] = s.max_consecutive_misses;
  j["skipped_cycles"] = s.skipped_cycles;
  j["answer_wait_timeouts"] = s.answer_wait_timeouts;
  j["telemetry_drops"] = s.telemetry_drops;
  j["event_drops"] = s.event_drops;
  j["commands_applied"] = s.commands_applied;
  j["commands_rejected"] = s.commands_rejected;
  nlohmann::json ev = nlohmann::json::object();
  for (std::size_t r = 0; r < loop.events_by_reason().size(); ++r)
    if (loop.events_by_reason()[r] != 0)
      ev[hyq::servo::ToString(static_cast<hyq::servo::EventReason>(r))] = loop.events_by_reason()[r];
  j["events"] = ev;
  nlohmann::json log = nlohmann::json::array();
  auto one = [](const hyq::servo::SafetyEvent& e) {
    return nlohmann::json{{"cycle", e.cycle},
                          {"time_s", 1e-9 * static_cast<double>(e.time_ns)},
                          {"from", hyq::servo::ToString(e.from)},
                          {"to", hyq::servo::ToString(e.to)},
                          {"reason", hyq::servo::ToString(e.reason)},
                          {"joint", e.joint},
                          {"bus", e.bus},
                          {"stop", hyq::servo::ToString(e.stop)},
                          {"detail", std::string(e.detail.data())}};
  };
  for (const auto& e : loop.first_events()) log.push_back(one(e));
  if (loop.events() > loop.first_events().size()) log.push_back(one(loop.last_event()));
  j["event_log"] = log;
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  // signals: blocked in every thread from the start (a SIGINT/SIGTERM during the start-up stays
  // pending and ends the bring-up as a stop request; before, one that came while the URDF was
  // loading killed the process), taken by the main thread with sigtimedwait
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  hyq::cli::CommandLine cl(argc, argv, "hyq-servod", hyq::cli::WithPaths(std::string(kHelp)));
  const Options opt = Parse(cl);
  hyq::servo::ServoConfig config;
  std::unique_ptr<hyq::dynamics::Model> model;
  try {
    config = hyq::config::LoadServoConfig(opt.config);
    Override(cl, opt, config);
    try {
      model = std::make_unique<hyq::dynamics::Model>(hyq::dynamics::LoadModelFromUrdf(config.urdf));
    } catch (const std::exception& e) {
      throw std::runtime_error(config.source + ": key 'robot.urdf': " + e.what());
    }
    // every bus's interface spec, and no two buses on one channel (what --check used to pass)
    std::vector<std::pair<std::string, std::string>> buses;
    for (const auto& b : config.hal.buses) buses.emplace_back(b.name, b.interface);
    try {
      hyq::drivers::CheckBusInterfaces(buses);
    } catch (const std::exception& e) {
      throw std::runtime_error(config.hal_file + ": " + e.what());
    }
    // the command key is checked here too, so that --check finds a key file others can read
    if (config.commands.enabled) (void)hyq::servo::LoadCommandKey(config.commands.key_file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hyq-servod: %s\n", e.what());
    return 1;
  }
  if (opt.check_host) {
    hyq::servo::HostCheckSettings hs;
    hs.cpu = hyq::servo::ResolveCpu(config.realtime.cpu, true, -1);
    hs.priority = config.realtime.priority;
    hs.lock_memory = config.realtime.lock_memory;
    hs.period_s = config.period_s();
    hs.budget_fraction = config.deadline.budget_fraction;
    hs.measure_s = opt.check_host_s;
    const std::vector<hyq::servo::HostItem> items = hyq::servo::CheckHost(hs);
    std::fputs(hyq::servo::FormatHostReport(items).c_str(), stdout);
    const hyq::servo::HostVerdict worst = hyq::servo::Worst(items);
    const bool refuse = config.realtime.require_rt_host && worst != hyq::servo::HostVerdict::kOk;
    std::printf("hyq-servod: host check: %s%s\n",
                worst == hyq::servo::HostVerdict::kOk ? "a real-time host"
                : worst == hyq::servo::HostVerdict::kWarn ? "runs, with less real-time margin than it should have"
                                                          : "not fit for the loop as configured",
                refuse ? " (realtime.require_rt_host: refused)"
                : worst != hyq::servo::HostVerdict::kOk ? " (warnings only: realtime.require_rt_host is false)"
                                                         : "");
    return refuse ? 4 : 0;
  }
  if (opt.check) {
    std::printf("%s: OK (%s, %g Hz, %s clock, %zu buses, reference %s, URDF %s)\n",
                opt.config.c_str(), hyq::servo::ToString(config.controller.kind), config.rate_hz(),
                hyq::servo::ToString(config.clock), config.hal.buses.size(),
                config.reference == hyq::servo::Reference::Kind::kTrot ? "trot"
                : config.reference == hyq::servo::Reference::Kind::kFigureEight ? "figure_eight"
                                                                                : "stand",
                config.urdf.c_str());
    return 0;
  }

  std::vector<std::unique_ptr<hyq::hal::CanChannel>> owned;
  std::vector<hyq::servo::LockstepChannel*> lockstep;
  std::vector<hyq::hal::CanChannel*> channels;
  std::unique_ptr<hyq::hal::Hal> hal;
  std::unique_ptr<hyq::servo::Telemetry> telemetry;
  std::unique_ptr<hyq::servo::ServoLoop> loop;
  try {
    for (const auto& b : config.hal.buses) {
      auto ch = hyq::drivers::OpenChannel(hyq::drivers::SpecForInterface(b.interface));
      // lock-step waits for every answer; real time waits for late ones (loop.answer_wait_periods)
      if (config.clock == hyq::servo::ClockMode::kLockstep || config.answer_wait_s() > 0.0) {
        auto ls = std::make_unique<hyq::servo::LockstepChannel>(std::move(ch));
        lockstep.push_back(ls.get());
        ch = std::move(ls);
      }
      channels.push_back(ch.get());
      owned.push_back(std::move(ch));
    }
    hal = std::make_unique<hyq::hal::Hal>(config.hal, channels);
    if (config.telemetry.enabled) {
      telemetry = std::make_unique<hyq::servo::Telemetry>(config.telemetry, config.commands);
    }
    loop = std::make_unique<hyq::servo::ServoLoop>(config, *model, *hal, telemetry.get());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hyq-servod: start-up failed: %s\n", e.what());
    return 1;
  }
  if (!opt.quiet)
    std::fprintf(stderr, "hyq-servod: %s, %g Hz, %s clock, %s; bringing %zu buses up\n",
                 hyq::servo::ToString(config.controller.kind), config.rate_hz(),
                 hyq::servo::ToString(config.clock),
                 telemetry ? config.telemetry.lcm_url.c_str() : "no telemetry",
                 config.hal.buses.size());

  if (telemetry) telemetry->Start();
  // the bring-up runs on the servo thread, after its real-time set-up, and the loop follows at
  // once on the same SYNC schedule: a board in OP trips on its own timer when SYNCs pause
  // (timing.device_setpoint_timeout_s), so there must be no gap between the two
  const std::int64_t wall0 = hyq::MonotonicNs();
  std::atomic<bool> servo_done{false};
  std::atomic<bool> rt_ready{false};  // release/acquire: the report is the servo thread's until then
  hyq::servo::RealtimeReport rt;
  std::string bringup_error;  // the servo thread's until servo_done
  // (lock-step: the boards run on the simulator's virtual time, which stands still between
  // SYNCs, so the bring-up stays where it was, before the servo thread's set-up)
  const bool lockstep_clock = config.clock == hyq::servo::ClockMode::kLockstep;
  // SIGINT / SIGTERM are blocked in every thread (the main loop takes them with sigtimedwait):
  // during the bring-up, a pending one ends it at once instead of after the bring-up timeout
  std::atomic<bool> stop_signalled{false};  // the main loop took SIGINT / SIGTERM
  const auto stop_pending = [&stop_signalled] {
    if (stop_signalled.load()) return true;
    sigset_t pending;
    sigemptyset(&pending);
    return sigpending(&pending) == 0 &&
           (sigismember(&pending, SIGINT) == 1 || sigismember(&pending, SIGTERM) == 1);
  };
  std::int64_t start_ns = 0;
  if (lockstep_clock) {
    try {
      start_ns = hyq::servo::BringUp(*hal, config, lockstep, stop_pending);
    } catch (const std::exception& e) {
      if (telemetry) telemetry->Stop();
      std::fprintf(stderr, "hyq-servod: bring-up failed: %s\n", e.what());
      return 1;
    }
  }
  std::thread servo([&] {
    hyq::servo::RealtimeConfig rtc = config.realtime;
    rtc.cpu = hyq::servo::ResolveCpu(rtc.cpu, !lockstep_clock, -1);  // auto: the last CPU
    rt = hyq::servo::SetUpRealtimeThread(rtc);
    rt_ready.store(true, std::memory_order_release);
    if (!lockstep_clock) {
      try {
        start_ns = hyq::servo::BringUp(*hal, config, lockstep, stop_pending);
      } catch (const std::exception& e) {
        bringup_error = e.what();
        servo_done.store(true, std::memory_order_release);
        return;
      }
    }
    loop->Start(start_ns);
    if (lockstep_clock)
      hyq::servo::RunLockstep(*loop, *hal, config, lockstep, start_ns);
    else {
      loop->SetAnswerWait(lockstep);
      hyq::servo::RunRealtime(*loop, config, start_ns);
    }
    servo_done.store(true, std::memory_order_release);
  });

  bool warned = false, overrun_done = false, stopped_in_fault = false;
  std::int64_t next_progress = hyq::MonotonicNs() + 1'000'000'000;
  // mode changes, the signal and the end are printed with --quiet too: they are the service's
  // record in the journal (journalctl -u hyq-servod)
  ServoMode last_mode = loop->published_mode();
  while (!servo_done.load(std::memory_order_acquire)) {
    const timespec wait{0, 50'000'000};
    const int sig = sigtimedwait(&signals, nullptr, &wait);
    if (sig == SIGINT || sig == SIGTERM) {
      std::fprintf(stderr, "hyq-servod: %s: controlled stop\n", strsignal(sig));
      stop_signalled.store(true);
      loop->RequestStop();
    }
    if (!warned && rt_ready.load(std::memory_order_acquire)) {  // the servo thread is set up
      warned = true;
      for (const auto& w : rt.warnings) std::fprintf(stderr, "hyq-servod: warning: %s\n", w.c_str());
    }
    const ServoMode mode = loop->published_mode();
    if (mode != last_mode) {
      std::fprintf(stderr, "hyq-servod: %s -> %s, cycle %llu\n", hyq::servo::ToString(last_mode),
                   hyq::servo::ToString(mode), static_cast<unsigned long long>(loop->published_cycles()));
      last_mode = mode;
    }
    if (opt.exit_on_fault && mode == ServoMode::kFault && !stopped_in_fault) {
      stopped_in_fault = true;
      loop->RequestStop();
    }
    if (!overrun_done && opt.overrun_at_s >= 0.0 && mode == ServoMode::kActive &&
        loop->published_active_s() >= opt.overrun_at_s) {
      overrun_done = true;
      loop->InjectOverrun(static_cast<std::int64_t>(opt.overrun_us * 1e3), opt.overrun_cycles);
    }
    if (!opt.quiet && hyq::MonotonicNs() >= next_progress) {
      next_progress += 1'000'000'000;
      std::fprintf(stderr, "hyq-servod: %s, cycle %llu\n", hyq::servo::ToString(mode),
                   static_cast<unsigned long long>(loop->published_cycles()));
    }
  }
  servo.join();
  if (!bringup_error.empty()) {
    if (telemetry) telemetry->Stop();
    std::fprintf(stderr, "hyq-servod: bring-up failed: %s\n", bringup_error.c_str());
    return 1;
  }
  if (telemetry) telemetry->Stop();  // publishes what is still queued
  const double wall_s = 1e-9 * static_cast<double>(hyq::MonotonicNs() - wall0);

  nlohmann::json summary = Summary(*loop, config, wall_s);
  {
    // the late-or-missing policy (docs/hal.md): held inputs per device, after the servo thread
    // has ended (join above), so the HAL's counters are read without a race
    std::uint64_t total = 0, late = 0;
    std::uint32_t longest = 0;
    nlohmann::json per = nlohmann::json::object();
    for (std::size_t b = 0; b < hal->num_buses(); ++b)
      for (const auto& d : hal->bus(b).devices()) {
        const auto& name = config.hal.buses[b].devices[static_cast<std::size_t>(d.config_index)].name;
        total += d.counters.held;
        late += d.counters.late;
        longest = std::max(longest, d.counters.max_held_in_row);
        if (d.counters.held != 0) per[name] = d.counters.held;
      }
    summary["held_inputs"] = {{"total", total},
                              {"max_in_row", longest},
                              {"limit", config.hal.timing.max_held_cycles},
                              {"late_answers", late},
                              {"per_device", per}};
  }
  if (telemetry) {
    const hyq::servo::TelemetryStats t = telemetry->stats();
    summary["command_channel"] = {{"received", t.commands_received},
                                  {"accepted", t.commands_accepted},
                                  {"rejected", t.commands_rejected},
                                  {"unauthenticated", t.commands_unauthenticated},
                                  {"replayed", t.commands_replayed}};
  }
  if (!opt.summary.empty()) std::ofstream(opt.summary) << summary.dump(2) << "\n";
  if (!opt.quiet) std::fprintf(stderr, "hyq-servod: summary\n%s\n", summary.dump(2).c_str());
  std::fprintf(stderr, "hyq-servod: ended in %s after %.2f s active, %llu deadline misses, events: %s\n",
               summary["final_mode"].get<std::string>().c_str(), summary["active_s"].get<double>(),
               static_cast<unsigned long long>(summary["deadline_misses"].get<std::uint64_t>()),
               summary["events"].empty() ? "none" : summary["events"].dump().c_str());
  return stopped_in_fault ? 3 : 0;
}
