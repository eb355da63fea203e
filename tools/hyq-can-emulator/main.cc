// hyq-can-emulator: HyQ's actuator boards and IMU on CAN (hal::Emulator).
//
// Default: the emulated devices answer on the configured buses (each bus's `interface`, opened
// with drivers::OpenChannel: "vcan0" → SocketCAN, "udp::43113" → the python-can compatible
// virtual bus; --interface BUS=SPEC overrides one), driven by whoever sends NMT and SYNC — the
// daemon, a python-can script, cansend. --loopback instead runs the emulator and a HAL master in
// this process over in-memory buses (a self-test of the protocol and the fault injection).
#include <poll.h>
#include <signal.h>
#include <time.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "hal/clock.h"
#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"
#include "tools/cli/command_line.h"
#include "tools/cli/install_paths.h"

namespace {

using hyq::MonotonicNs;

struct Options {
  std::string config = hyq::cli::DefaultHalConfig();
  std::map<std::string, std::string> interfaces;  // bus name → channel spec
  double seconds = 0.0;  // 0: until SIGINT / SIGTERM (devices mode); loopback default 2 s
  bool loopback = false;
  double drop_probability = 0.0;
  int silent_joint = -1;
};

constexpr const char* kHelp =
    "usage: hyq-can-emulator [--config FILE] [--interface BUS=SPEC]... [--seconds S]\n"
    "                        [--drop-probability P] [--silent-joint NAME] [--loopback]\n"
    "HyQ's 12 actuator boards and IMU, answering NMT, SYNC and RPDOs on the configured\n"
    "CAN buses until SIGINT/SIGTERM, then printing their counters.\n"
    "  --config FILE         HAL configuration (default @config@/hyq_hal.yaml)\n"
    "  --interface BUS=SPEC  open bus BUS on SPEC (socketcan:vcan0, udp::43113, ...;\n"
    "                        docs/drivers.md) instead of its configured interface\n"
    "  --seconds S           stop after S seconds (default: run until a signal;\n"
    "                        2 with --loopback)\n"
    "  --loopback            emulator + HAL master in this process (self-test)\n"
    "  --drop-probability P  every board drops each TPDO with probability P\n"
    "  --silent-joint NAME   this joint's board never answers (e.g. lh_kfe_joint)\n";

Options Parse(int argc, char** argv) {
  Options o;
  hyq::cli::CommandLine cl(argc, argv, "hyq-can-emulator", hyq::cli::WithPaths(std::string(kHelp)));
  while (cl.Next()) {
    if (cl.Flag("--loopback")) {
      o.loopback = true;
    } else if (cl.Flag("--interface")) {
      auto [bus, spec] = cl.KeyValue("BUS=SPEC");
      o.interfaces[std::move(bus)] = std::move(spec);
    } else if (cl.Flag("--config")) {
      o.config = cl.Value();
    } else if (cl.Flag("--seconds")) {
      o.seconds = cl.Number(1e-9, 1e9, "a positive number");
    } else if (cl.Flag("--drop-probability")) {
      o.drop_probability = cl.Number(0.0, 1.0);
    } else if (cl.Flag("--silent-joint")) {
      const std::string name = cl.Value();
      o.silent_joint = hyq::hal::JointIndex(name);
      if (o.silent_joint < 0) cl.BadValue("a joint name (e.g. lh_kfe_joint)", name);
    } else {
      cl.Unknown();
    }
  }
  return o;
}

void SleepUntil(std::int64_t t_ns) {
  timespec t{};
  t.tv_sec = t_ns / 1'000'000'000;
  t.tv_nsec = t_ns % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) != 0) {
  }
}

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

void PrintEmulatorCounters(const hyq::hal::Emulator& emu, const hyq::hal::HalConfig& cfg) {
  for (std::size_t b = 0; b < cfg.buses.size(); ++b) {
    const auto& c = emu.counters(static_cast<int>(b));
    std::printf(
        "bus %-3s emulator: rx %llu tx %llu syncs %llu rpdos %llu malformed %llu dropped %llu "
        "corrupted %llu tx_failed %llu\n",
        cfg.buses[b].name.c_str(), static_cast<unsigned long long>(c.rx_frames),
        static_cast<unsigned long long>(c.tx_frames), static_cast<unsigned long long>(c.syncs),
        static_cast<unsigned long long>(c.rpdos), static_cast<unsigned long long>(c.malformed_rx),
        static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.corrupted),
        static_cast<unsigned long long>(c.tx_failed));
  }
}

// The devices on real (or virtual) buses, until a signal or --seconds.
int RunDevices(const Options& o, hyq::hal::HalConfig cfg) {
  using namespace hyq::hal;
  std::vector<std::unique_ptr<CanChannel>> owned;
  std::vector<CanChannel*> channels;
  std::vector<pollfd> fds;
  for (BusConfig& b : cfg.buses) {
    const auto it = o.interfaces.find(b.name);
    const std::string spec =
        hyq::drivers::SpecForInterface(it != o.interfaces.end() ? it->second : b.interface);
    owned.push_back(hyq::drivers::OpenChannel(spec));
    channels.push_back(owned.back().get());
    const int fd = owned.back()->poll_fd();
    if (fd >= 0) fds.push_back({fd, POLLIN, 0});
    std::printf("bus %-3s on %s\n", b.name.c_str(), spec.c_str());
  }
  Emulator emu(cfg, channels);
  for (int j = 0; j < kNumJoints; ++j) {
    emu.joint_faults(j).drop_probability = o.drop_probability;
    if (j == o.silent_joint) emu.joint_faults(j).silent = true;
  }
  signal(SIGINT, OnSignal);
  signal(SIGTERM, OnSignal);
  const std::int64_t start = MonotonicNs();
  const auto end = o.seconds > 0 ? start + static_cast<std::int64_t>(o.seconds * 1e9)
                                 : std::numeric_limits<std::int64_t>::max();
  std::fflush(stdout);
  while (!g_stop && MonotonicNs() < end) {
    // wake on any received frame, and at least every 1 ms for heartbeats and delayed frames
    if (poll(fds.data(), fds.size(), 1) < 0 && errno != EINTR) break;
    emu.Poll(MonotonicNs());
  }
  PrintEmulatorCounters(emu, cfg);
  return 0;
}

int RunLoopback(const Options& o, const hyq::hal::HalConfig& cfg) {
  using namespace hyq::hal;
  std::vector<std::unique_ptr<LoopbackBus>> wires;
  std::vector<CanChannel*> master, devices;
  for (const BusConfig& b : cfg.buses) {
    wires.push_back(std::make_unique<LoopbackBus>(b.name, 2, 256, true));
    master.push_back(&wires.back()->endpoint(0));
    devices.push_back(&wires.back()->endpoint(1));
  }
  Hal hal(cfg, master);
  Emulator emu(cfg, devices);
  const auto period = static_cast<std::int64_t>(cfg.timing.cycle_period_s * 1e9);
  std::int64_t now = MonotonicNs();
  emu.Poll(now);
  RunBringUp(hal, DeviceState::kOp, now, [&] {
    emu.Poll(now);
    now += period;
    SleepUntil(now);
    return now;
  });
  std::printf("bring-up: all %s\n", ToString(DeviceState::kOp));
  for (int j = 0; j < kNumJoints; ++j) {
    emu.joint_faults(j).drop_probability = o.drop_probability;
    if (j == o.silent_joint) emu.joint_faults(j).silent = true;
  }
  const double seconds = o.seconds > 0 ? o.seconds : 2.0;
  const auto cycles = static_cast<long>(seconds / cfg.timing.cycle_period_s);
  long not_ok = 0;
  for (long k = 0; k < cycles; ++k) {
    emu.Poll(now);
    now += period;
    SleepUntil(now);
    if (hal.Read(now) != HalStatus::kOk) ++not_ok;
    for (int j = 0; j < kNumJoints; ++j)
      hal.image().commands[static_cast<std::size_t>(j)].torque_Nm = 0.0;
    (void)hal.Write(now);
  }
  std::printf("%ld cycles, %ld with a fault status\n", cycles, not_ok);
  for (std::size_t b = 0; b < hal.num_buses(); ++b) {
    const BusCounters& c = hal.bus(b).counters();
    std::printf(
        "bus %-3s rx %llu tx %llu wkc_faults %llu missing %llu late %llu duplicate %llu "
        "malformed %llu emcy %llu\n",
        hal.bus(b).config().name.c_str(), static_cast<unsigned long long>(c.rx_frames),
        static_cast<unsigned long long>(c.tx_frames), static_cast<unsigned long long>(c.wkc_faults),
        static_cast<unsigned long long>(c.missing), static_cast<unsigned long long>(c.late),
        static_cast<unsigned long long>(c.duplicate), static_cast<unsigned long long>(c.malformed),
        static_cast<unsigned long long>(c.emcy));
  }
  std::printf("%s\n", hal.BringUpReport(now).c_str());
  return hal.AllIn(DeviceState::kOp) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Parse(argc, argv);
  return hyq::cli::Run("hyq-can-emulator", [&] {
    const hyq::hal::HalConfig cfg = hyq::config::LoadHalConfig(o.config);
    return o.loopback ? RunLoopback(o, cfg) : RunDevices(o, cfg);
  });
}
