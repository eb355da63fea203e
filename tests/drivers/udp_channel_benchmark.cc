// Virtual CAN cost: send + drain per frame, and the loopback round trip of a 13-frame burst
// (SYNC + one RPDO per joint out, 13 frames back), median and 99th percentile. Runs inside a
// private network namespace (tests/drivers/in_netns.sh), single-threaded: the "devices" side
// drains and answers in the same thread, so this is the cost of our stack plus the kernel's
// loopback, without scheduler wake-ups.
//
//   tests/drivers/in_netns.sh build/release/tests/drivers/drivers_benchmark
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <string>
#include <vector>

#include <unistd.h>

#include "drivers/candump.h"
#include "drivers/msgpack_frame.h"
#include "drivers/shm_channel.h"
#include "drivers/udp_multicast_channel.h"

namespace hyq::drivers {
namespace {

using hal::CanFrame;
using hal::CanStatus;

bool InNetns() {
  const char* v = std::getenv("HYQ_NETNS");
  return v != nullptr && std::string(v) == "1";
}

CanFrame Frame(std::uint32_t id, std::size_t len, bool fd) {
  CanFrame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(len);
  f.flags = fd ? CanFrame::kFd : 0;
  for (std::size_t i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(i);
  return f;
}

// Busy-drains `ch` until `n` frames came; false after ~1 s.
bool DrainN(hal::CanChannel& ch, std::span<CanFrame> buf, std::size_t n) {
  std::size_t got = 0;
  for (long spins = 0; got < n; ++spins) {
    std::size_t k = 0;
    if (ch.Receive(buf, &k) != CanStatus::kOk) return false;
    got += k;
    if (spins > 20'000'000) return false;
  }
  return true;
}

UdpMulticastOptions Opts() {
  UdpMulticastOptions o;
  o.port = 43200;
  o.receive_buffer_bytes = 1 << 21;
  return o;
}

void BM_UdpSendAndDrainPerFrame(benchmark::State& state) {
  if (!InNetns()) {
    state.SkipWithError("run inside tests/drivers/in_netns.sh (a private network namespace)");
    return;
  }
  const auto n = static_cast<std::size_t>(state.range(0));
  const bool fd = state.range(1) != 0;
  UdpMulticastChannel a(Opts()), b(Opts());
  std::vector<CanFrame> burst;
  for (std::size_t i = 0; i < n; ++i) burst.push_back(Frame(0x180 + static_cast<std::uint32_t>(i), fd ? 32 : 8, fd));
  std::vector<CanFrame> out(64);
  for (auto _ : state) {
    std::size_t sent = 0;
    if (a.Send(burst, &sent) != CanStatus::kOk || !DrainN(b, out, n)) {
      state.SkipWithError("frames lost");
      break;
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
  state.counters["per_frame"] = benchmark::Counter(
      static_cast<double>(state.iterations() * n),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_UdpSendAndDrainPerFrame)
    ->ArgNames({"frames", "fd"})
    ->Args({1, 0})
    ->Args({13, 0})
    ->Args({13, 1})
    ->Args({64, 1})
    ->UseRealTime();

// 13 frames out, drained by the devices' channel, 13 back, drained by the master's: the
// transport's own cost per lock-step cycle and bus, on one thread (no hand-off between processes)
void RoundTrip13(benchmark::State& state, hal::CanChannel& master, hal::CanChannel& devices) {
  constexpr std::size_t kBurst = 13;  // SYNC + 12 RPDOs out; 12 TPDOs + IMU back
  const bool fd = state.range(0) != 0;
  std::vector<CanFrame> out_burst, in_burst;
  for (std::uint32_t i = 0; i < kBurst; ++i) {
    out_burst.push_back(Frame(i == 0 ? 0x080 : 0x200 + i, i == 0 ? 0 : (fd ? 16 : 8), fd && i));
    in_burst.push_back(Frame(0x180 + i, fd ? 32 : 8, fd));
  }
  std::vector<CanFrame> buf(64);
  std::vector<double> rtt_us;
  rtt_us.reserve(1 << 20);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    std::size_t sent = 0;
    if (master.Send(out_burst, &sent) != CanStatus::kOk || !DrainN(devices, buf, kBurst) ||
        devices.Send(in_burst, &sent) != CanStatus::kOk || !DrainN(master, buf, kBurst)) {
      state.SkipWithError("frames lost");
      break;
    }
    const auto t1 = std::chrono::steady_clock::now();
    if (rtt_us.size() < rtt_us.capacity())
      rtt_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  if (rtt_us.empty()) return;
  std::sort(rtt_us.begin(), rtt_us.end());
  state.counters["median_us"] = rtt_us[rtt_us.size() / 2];
  state.counters["p99_us"] = rtt_us[std::min(rtt_us.size() - 1, rtt_us.size() * 99 / 100)];
  state.counters["samples"] = static_cast<double>(rtt_us.size());
}

void BM_UdpRoundTrip13(benchmark::State& state) {
  if (!InNetns()) {
    state.SkipWithError("run inside tests/drivers/in_netns.sh (a private network namespace)");
    return;
  }
  UdpMulticastChannel master(Opts()), devices(Opts());
  RoundTrip13(state, master, devices);
}
BENCHMARK(BM_UdpRoundTrip13)->ArgName("fd")->Arg(0)->Arg(1)->UseRealTime();

void BM_ShmRoundTrip13(benchmark::State& state) {
  ShmOptions o;
  o.group = "bench-" + std::to_string(::getpid());
  o.bus = "lf";
  o.side = ShmSide::kDevices;
  ShmChannel devices(o);
  o.side = ShmSide::kMaster;
  ShmChannel master(o);
  RoundTrip13(state, master, devices);
}
BENCHMARK(BM_ShmRoundTrip13)->ArgName("fd")->Arg(0)->Arg(1)->UseRealTime();

void BM_DatagramEncodeDecode(benchmark::State& state) {
  const CanFrame f = Frame(0x181, 64, true);
  std::array<std::uint8_t, kMaxDatagramBytes> buf;
  CanFrame g;
  for (auto _ : state) {
    const std::size_t n = EncodeFrameDatagram(f, 1.0, buf);
    benchmark::DoNotOptimize(DecodeFrameDatagram({buf.data(), n}, &g));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_DatagramEncodeDecode);

void BM_CandumpFormatParse(benchmark::State& state) {
  const CanFrame f = Frame(0x181, 64, true);
  char line[kMaxCandumpLine];
  CandumpRecord rec;
  const char* why = nullptr;
  for (auto _ : state) {
    const std::size_t n = FormatCandumpLine(f, "vcan0", line);
    benchmark::DoNotOptimize(ParseCandumpLine({line, n}, &rec, &why));
  }
}
BENCHMARK(BM_CandumpFormatParse);

}  // namespace
}  // namespace hyq::drivers

BENCHMARK_MAIN();
