// hyq-can-emulator: HyQ's actuator boards and IMU on CAN (hal::Emulator).
//
// Until the drivers library is wired in (SocketCAN / UDP multicast channels from drivers/, one per
// configured bus interface), the only transport is --loopback: the emulator and a HAL master run
// in this process over in-memory buses, in real time at the configured SYNC period, and the tool
// prints the bring-up report and the counters. That is a self-test of the protocol and of the
// fault injection, and the skeleton the drivers-backed mode plugs into (OpenDeviceChannels).
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "config/hal_config_loader.h"
#include "hal/emulator.h"
#include "hal/hal.h"
#include "hal/loopback_bus.h"

namespace {

struct Options {
  std::string config = "config/hyq_hal.yaml";
  double seconds = 2.0;
  bool loopback = false;
  double drop_probability = 0.0;
  int silent_joint = -1;
};

[[noreturn]] void Usage(int code) {
  std::fprintf(code == 0 ? stdout : stderr,
               "usage: hyq-can-emulator --loopback [--config FILE] [--seconds S]\n"
               "                        [--drop-probability P] [--silent-joint NAME]\n"
               "  --loopback            emulator + HAL master in this process (self-test)\n"
               "  --config FILE         HAL configuration (default config/hyq_hal.yaml)\n"
               "  --seconds S           run time (default 2)\n"
               "  --drop-probability P  every board drops each TPDO with probability P\n"
               "  --silent-joint NAME   this joint's board never answers (e.g. lh_kfe_joint)\n");
  std::exit(code);
}

Options Parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) Usage(2);
      return argv[++i];
    };
    if (a == "--loopback") o.loopback = true;
    else if (a == "--config") o.config = value();
    else if (a == "--seconds") o.seconds = std::stod(value());
    else if (a == "--drop-probability") o.drop_probability = std::stod(value());
    else if (a == "--silent-joint") {
      const std::string name = value();
      o.silent_joint = hyq::hal::JointIndex(name);
      if (o.silent_joint < 0) {
        std::fprintf(stderr, "hyq-can-emulator: unknown joint '%s'\n", name.c_str());
        std::exit(2);
      }
    } else if (a == "-h" || a == "--help") Usage(0);
    else Usage(2);
  }
  return o;
}

std::int64_t Now() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

void SleepUntil(std::int64_t t_ns) {
  timespec t{};
  t.tv_sec = t_ns / 1'000'000'000;
  t.tv_nsec = t_ns % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) != 0) {
  }
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
  std::int64_t now = Now();
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
  const auto cycles = static_cast<long>(o.seconds / cfg.timing.cycle_period_s);
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
    std::printf("bus %-3s rx %llu tx %llu wkc_faults %llu missing %llu late %llu duplicate %llu "
                "malformed %llu emcy %llu\n",
                hal.bus(b).config().name.c_str(), static_cast<unsigned long long>(c.rx_frames),
                static_cast<unsigned long long>(c.tx_frames),
                static_cast<unsigned long long>(c.wkc_faults),
                static_cast<unsigned long long>(c.missing), static_cast<unsigned long long>(c.late),
                static_cast<unsigned long long>(c.duplicate),
                static_cast<unsigned long long>(c.malformed),
                static_cast<unsigned long long>(c.emcy));
  }
  std::printf("%s\n", hal.BringUpReport(now).c_str());
  return hal.AllIn(DeviceState::kOp) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Parse(argc, argv);
  try {
    const hyq::hal::HalConfig cfg = hyq::config::LoadHalConfig(o.config);
    if (!o.loopback) {
      std::fprintf(stderr, "hyq-can-emulator: only --loopback is available until the drivers "
                           "library (SocketCAN, UDP multicast) is linked in\n");
      return 2;
    }
    return RunLoopback(o, cfg);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hyq-can-emulator: %s\n", e.what());
    return 1;
  }
}
