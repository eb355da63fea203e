// hyq-candump: record any bus the channel factory opens to a candump log, or play a log onto it.
//
//   hyq-candump [-o FILE] [-L NAME] [-n COUNT] [-t SECONDS] SPEC     record (default: stdout)
//   hyq-candump --play LOG [--as-fast] [-L NAME] SPEC                  play LOG's frames onto SPEC
//
// SPEC is a channel spec (drivers/channel_factory.h), e.g. socketcan:vcan0 or
// udp:239.74.163.2:43113. NAME is the interface name written in (or selected from) the log;
// by default the SocketCAN interface, else "can0" when recording and every line when playing.
// Recording stops after COUNT frames, after SECONDS, or on SIGINT/SIGTERM, and flushes the log.
#include <poll.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "drivers/candump.h"
#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "hal/clock.h"
#include "tools/cli/command_line.h"

namespace {

using hyq::MonotonicNs;

volatile std::sig_atomic_t g_stop = 0;

void OnSignal(int) { g_stop = 1; }

void SleepUs(long us) { std::this_thread::sleep_for(std::chrono::microseconds(us)); }

constexpr const char* kHelp =
    "usage: hyq-candump [-o FILE] [-L NAME] [-n COUNT] [-t SECONDS] SPEC\n"
    "       hyq-candump --play LOG [--as-fast] [-L NAME] SPEC\n"
    "Records a CAN bus to a candump log (default: standard output), or plays a log onto it.\n"
    "SPEC: socketcan:IF | socketcan-fd:IF | socketcan-classic:IF | "
    "udp[:GROUP[:PORT]][,ttl=N,...] | replay:PATH\n"
    "  -o FILE      the log to write (- for standard output)\n"
    "  -L NAME      the interface name written in (or selected from) the log\n"
    "  -n COUNT     stop after COUNT frames (0: no limit)\n"
    "  -t SECONDS   stop after SECONDS (0: no limit)\n"
    "  --play LOG   play LOG's frames onto SPEC instead\n"
    "  --as-fast    with --play: as fast as the bus takes them, not at the logged times\n";

int Record(hyq::hal::CanChannel& ch, const std::string& out_path, const std::string& name,
           long count, double seconds) {
  hyq::drivers::CandumpWriter writer =
      out_path.empty() || out_path == "-" ? hyq::drivers::CandumpWriter(stdout, name)
                                          : hyq::drivers::CandumpWriter(out_path, name);
  std::fprintf(stderr, "hyq-candump: recording %.*s as '%s'\n",
               static_cast<int>(ch.name().size()), ch.name().data(), name.c_str());
  std::fflush(stderr);
  std::vector<hyq::hal::CanFrame> buf(256);
  const std::int64_t end =
      seconds > 0 ? MonotonicNs() + static_cast<std::int64_t>(seconds * 1e9) : INT64_MAX;
  long recorded = 0, unwritten = 0;
  const int fd = ch.poll_fd();
  while (g_stop == 0 && (count <= 0 || recorded < count) && MonotonicNs() < end) {
    std::size_t n = 0;
    const hyq::hal::CanStatus s = ch.Receive(buf, &n);
    if (s != hyq::hal::CanStatus::kOk) {
      std::fprintf(stderr, "hyq-candump: receive failed: %s (errno %d)\n",
                   hyq::hal::ToString(s), ch.counters().last_errno);
      return 1;
    }
    for (std::size_t i = 0; i < n && (count <= 0 || recorded < count); ++i, ++recorded)
      unwritten += writer.Write(buf[i]) ? 0 : 1;
    if (n > 0) {
      unwritten += writer.Flush() ? 0 : 1;
    } else if (fd >= 0) {
      pollfd p{fd, POLLIN, 0};
      (void)poll(&p, 1, 100);  // wakes for data, and every 100 ms to check stop/timeout
    } else {
      SleepUs(200);
    }
  }
  unwritten += writer.Flush() ? 0 : 1;
  const auto& c = ch.counters();
  std::fprintf(stderr,
               "hyq-candump: %ld frames recorded; rx %llu, overflow %llu, error frames %llu, "
               "bad %llu\n",
               recorded, static_cast<unsigned long long>(c.rx_frames),
               static_cast<unsigned long long>(c.rx_overflow),
               static_cast<unsigned long long>(c.error_frames),
               static_cast<unsigned long long>(c.bad_frames));
  if (unwritten > 0) {  // a full disk (or /dev/full): the log is incomplete, not a success
    std::fprintf(stderr, "hyq-candump: %s: %ld write(s) failed: the log is incomplete\n",
                 out_path.empty() ? "-" : out_path.c_str(), unwritten);
    return 1;
  }
  return 0;
}

int Play(hyq::hal::CanChannel& ch, const std::string& log_path, const std::string& name,
         bool as_fast) {
  hyq::drivers::ReplayChannel replay(hyq::drivers::ReadCandumpFile(log_path).records, name,
                                     as_fast ? hyq::drivers::ReplayTiming::kAsFast
                                             : hyq::drivers::ReplayTiming::kRealTime,
                                     true, "replay:" + log_path);
  std::vector<hyq::hal::CanFrame> buf(256);
  std::size_t played = 0;
  while (g_stop == 0 && !replay.finished()) {
    std::size_t n = 0;
    (void)replay.Receive(buf, &n);
    std::size_t done = 0;
    while (done < n && g_stop == 0) {
      std::size_t sent = 0;
      const hyq::hal::CanStatus s =
          ch.Send(std::span<const hyq::hal::CanFrame>(buf.data() + done, n - done), &sent);
      done += sent;
      if (s == hyq::hal::CanStatus::kWouldBlock) {
        SleepUs(100);
      } else if (s != hyq::hal::CanStatus::kOk) {
        std::fprintf(stderr, "hyq-candump: send failed after %zu frames: %s\n", played + done,
                     hyq::hal::ToString(s));
        return 1;
      }
    }
    played += done;
    if (n == 0) SleepUs(100);
  }
  std::fprintf(stderr, "hyq-candump: played %zu frames from %s\n", played, log_path.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_path, name, play_path, spec;
  long count = 0;
  double seconds = 0;
  bool as_fast = false;
  hyq::cli::CommandLine cl(argc, argv, "hyq-candump", kHelp);
  while (cl.Next()) {
    if (cl.Flag("-o")) {
      out_path = cl.Value();
    } else if (cl.Flag("-L")) {
      name = cl.Value();
    } else if (cl.Flag("-n")) {
      count = static_cast<long>(cl.Integer(0, std::numeric_limits<long>::max(), "a frame count"));
    } else if (cl.Flag("-t")) {
      seconds = cl.Number(0.0, 1e9, "a number of seconds >= 0");
    } else if (cl.Flag("--play")) {
      play_path = cl.Value();
    } else if (cl.Flag("--as-fast")) {
      as_fast = true;
    } else if (cl.IsOption()) {
      cl.Unknown();
    } else if (spec.empty()) {
      spec = cl.arg();
    } else {
      cl.Fail("expected one channel spec, found another: '" + cl.arg() + "'");
    }
  }
  if (spec.empty()) cl.Fail("expected a channel spec (SPEC), found none");
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  // a ChannelError, or bad_alloc for a log beyond memory: exit 1
  return hyq::cli::Run("hyq-candump", [&] {
    const hyq::drivers::ChannelSpec parsed = hyq::drivers::ParseChannelSpec(spec);
    if (name.empty() && play_path.empty()) {
      const auto* sc = std::get_if<hyq::drivers::SocketCanOptions>(&parsed);
      name = sc != nullptr ? sc->interface : "can0";
    }
    auto ch = hyq::drivers::OpenChannel(parsed);
    return play_path.empty() ? Record(*ch, out_path, name, count, seconds)
                             : Play(*ch, play_path, name, as_fast);
  });
}
