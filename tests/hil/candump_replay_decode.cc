// hil_candump_decode: plays candump logs of HyQ's buses back through the drivers' replay channel
// (spec "replay:PATH,iface=BUS") and decodes every actuator TPDO1 with the HAL's own protocol
// decoder and calibration (hal::DecodeActuatorTpdo, EncoderCountsToRad, EncoderRateToRadPerSec,
// EffortCountsToTorque: the functions hal::Hal uses to fill JointInput), printing one CSV line per
// decoded TPDO:
//
//   bus,seq,sync_counter,joint,q_rad,qd_rad_s,tau_Nm        (doubles as %.17g: exact round trip)
//
// seq is the SYNC counter unwrapped along the bus's log (1..240 wraps; 0 at the first TPDO), so
// that a constant offset maps it to the daemon's cycle. Usage:
//   hil_candump_decode HAL_YAML BUS=LOG [BUS=LOG ...]
// Exit 1 on a TPDO that does not decode (reported on stderr with the count).
#include <cinttypes>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "config/hal_config_loader.h"
#include "drivers/channel_factory.h"
#include "hal/calibration.h"
#include "hal/hal_config.h"
#include "hal/protocol.h"

int main(int argc, char** argv) try {
  using namespace hyq;
  if (argc < 3) {
    std::fprintf(stderr, "usage: hil_candump_decode HAL_YAML BUS=LOG [BUS=LOG ...]\n");
    return 2;
  }
  const hal::HalConfig config = config::LoadHalConfig(argv[1]);
  int bad_total = 0;
  for (int a = 2; a < argc; ++a) {
    const std::string arg = argv[a];
    const auto eq = arg.find('=');
    if (eq == std::string::npos) throw std::runtime_error("expected BUS=LOG, found '" + arg + "'");
    const std::string bus_name = arg.substr(0, eq), path = arg.substr(eq + 1);
    const hal::BusConfig* bus = nullptr;
    for (const auto& b : config.buses)
      if (b.name == bus_name) bus = &b;
    if (bus == nullptr) throw std::runtime_error("no bus '" + bus_name + "' in " + argv[1]);
    int joint_of_node[128];
    for (int& j : joint_of_node) j = -1;
    for (const auto& d : bus->devices)
      if (d.kind == hal::DeviceKind::kActuator) joint_of_node[d.node_id] = d.joint;

    auto channel = drivers::OpenChannel("replay:" + path + ",iface=" + bus_name);
    auto* replay = dynamic_cast<drivers::ReplayChannel*>(channel.get());
    std::vector<hal::CanFrame> frames(64);
    std::int64_t seq = -1;
    int last_counter = 0;
    long decoded = 0, bad = 0, syncs = 0;
    while (!replay->finished()) {
      std::size_t n = 0;
      if (channel->Receive(frames, &n) != hal::CanStatus::kOk)
        throw std::runtime_error(path + ": replay channel failed");
      for (std::size_t i = 0; i < n; ++i) {
        const hal::CanFrame& f = frames[i];
        const hal::FrameAddress addr = hal::Classify(f.id);
        if (addr.kind == hal::FrameKind::kSync) ++syncs;
        if (addr.kind != hal::FrameKind::kTpdo1 || joint_of_node[addr.node] < 0) continue;
        hal::ActuatorTpdo p;
        if (hal::DecodeActuatorTpdo(f, addr.node, &p) != hal::PdoStatus::kOk) {
          ++bad;
          continue;
        }
        if (seq < 0) {
          seq = 0;
        } else {
          seq += (p.sync_counter - last_counter + 240) % 240;
        }
        last_counter = p.sync_counter;
        const int j = joint_of_node[addr.node];
        const hal::JointCalibration& c = config.joints[j];
        const double q = hal::EncoderCountsToRad(c, p.position_counts);
        const double qd = hal::EncoderRateToRadPerSec(c, p.velocity_counts_s);
        const double tau = hal::EffortCountsToTorque(c, p.effort_counts, q);
        std::printf("%s,%" PRId64 ",%d,%d,%.17g,%.17g,%.17g\n", bus_name.c_str(), seq,
                    p.sync_counter, j, q, qd, tau);
        ++decoded;
      }
    }
    std::fprintf(stderr, "%s: %zu frames, %ld SYNC, %ld actuator TPDOs decoded, %ld undecodable\n",
                 path.c_str(), replay->size(), syncs, decoded, bad);
    bad_total += bad;
  }
  return bad_total == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "hil_candump_decode: %s\n", e.what());
  return 1;
}
