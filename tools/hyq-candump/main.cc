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
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "drivers/candump.h"
#include "drivers/channel_error.h"
#include "drivers/channel_factory.h"
#include "hal/clock.h"

namespace {

using hyq::MonotonicNs;

volatile std::sig_atomic_t g_stop = 0;

void OnSignal(int) { g_stop = 1; }

void SleepUs(long us) { std::this_thread::sleep_for(std::chrono::microseconds(us)); }

// The channel's receive socket when it has one (to sleep in poll), else -1.
int Usage(const char* why) {
  std::fprintf(stderr,
               "hyq-candump: %s\n"
               "usage: hyq-candump [-o FILE] [-L NAME] [-n COUNT] [-t SECONDS] SPEC\n"
               "       hyq-candump --play LOG [--as-fast] [-L NAME] SPEC\n"
               "SPEC: socketcan:IF | socketcan-fd:IF | socketcan-classic:IF | "
               "udp[:GROUP[:PORT]][,ttl=N,...] | replay:PATH\n",
               why);
  return 2;
}

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
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "-o") {
        out_path = value();
      } else if (a == "-L") {
        name = value();
      } else if (a == "-n") {
        count = std::stol(value());
      } else if (a == "-t") {
        seconds = std::stod(value());
      } else if (a == "--play") {
        play_path = value();
      } else if (a == "--as-fast") {
        as_fast = true;
      } else if (a == "-h" || a == "--help") {
        Usage("record or play a CAN bus");
        return 0;
      } else if (!a.empty() && a[0] == '-') {
        return Usage(("unknown option " + a).c_str());
      } else if (spec.empty()) {
        spec = a;
      } else {
        return Usage(("unexpected argument " + a).c_str());
      }
    } catch (const std::exception& e) {
      return Usage(e.what());
    }
  }
  if (spec.empty()) return Usage("no channel spec");
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  try {
    const hyq::drivers::ChannelSpec parsed = hyq::drivers::ParseChannelSpec(spec);
    if (name.empty() && play_path.empty()) {
      const auto* sc = std::get_if<hyq::drivers::SocketCanOptions>(&parsed);
      name = sc != nullptr ? sc->interface : "can0";
    }
    auto ch = hyq::drivers::OpenChannel(parsed);
    return play_path.empty() ? Record(*ch, out_path, name, count, seconds)
                             : Play(*ch, play_path, name, as_fast);
  } catch (const std::exception& e) {  // ChannelError, or bad_alloc for a log beyond memory
    std::fprintf(stderr, "hyq-candump: %s\n", e.what());
    return 1;
  }
}
