#include "hal/bus_load.h"

#include <cstdio>

#include "hal/config_error.h"
#include "hal/protocol.h"

namespace hyq::hal {
namespace {

std::uint32_t RoundUpToFdLength(std::uint32_t n) noexcept {
  for (std::uint32_t len : {0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 12u, 16u, 20u, 24u, 32u, 48u})
    if (n <= len) return len;
  return 64;
}

std::string Percent(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * x);
  return buf;
}

std::string Micros(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f us", 1e6 * seconds);
  return buf;
}

void Add(BusLoadReport* r, const BusConfig& bus, std::string what, std::uint32_t bytes) {
  LoadItem item;
  item.what = std::move(what);
  item.data_bytes = bytes;
  item.fd = bus.fd;
  item.bitrate_switch = bus.fd;
  item.time_s = FrameTime_s(bytes, bus.fd, bus.fd, bus.nominal_bitrate, bus.data_bitrate);
  r->busy_time_s += item.time_s;
  r->items.push_back(std::move(item));
}

}  // namespace

std::uint32_t ClassicFrameBits(std::uint32_t n) noexcept {
  // 47 + 8n + floor((34 + 8n - 1) / 4)  (1)
  return 47 + 8 * n + (34 + 8 * n - 1) / 4;
}

FdFrameBits FdFrameBitCount(std::uint32_t data_bytes) noexcept {
  const std::uint32_t n = RoundUpToFdLength(data_bytes);
  const std::uint32_t crc = n <= 16 ? 17 : 21;
  const std::uint32_t fixed_stuff = (4 + crc + 3) / 4;
  FdFrameBits b;
  b.nominal = 17 + 4 + 1 + 1 + 1 + 7 + 3;                                       // (2)
  b.data = 1 + 4 + 8 * n + ((21 + 8 * n) / 4 - 4) + 4 + crc + fixed_stuff;    // (3)
  return b;
}

double FrameTime_s(std::uint32_t data_bytes, bool fd, bool bitrate_switch,
                   std::uint32_t nominal_bitrate, std::uint32_t data_bitrate) noexcept {
  if (!fd) return static_cast<double>(ClassicFrameBits(data_bytes)) / nominal_bitrate;
  const FdFrameBits b = FdFrameBitCount(data_bytes);
  const double data_rate = bitrate_switch ? static_cast<double>(data_bitrate) : nominal_bitrate;
  return static_cast<double>(b.nominal) / nominal_bitrate + static_cast<double>(b.data) / data_rate;
}

BusLoadReport ComputeBusLoad(const BusConfig& bus, double cycle_period_s, bool heartbeats) {
  BusLoadReport r;
  r.bus = bus.name;
  r.cycle_period_s = cycle_period_s;
  Add(&r, bus, "SYNC", kSyncLen);
  for (const DeviceConfig& d : bus.devices) {
    if (d.kind == DeviceKind::kActuator) {
      if (bus.fd) {
        Add(&r, bus, "TPDO1 " + d.name, kActuatorTpdoLen);
      } else {
        Add(&r, bus, "TPDO1 " + d.name, 8);
        Add(&r, bus, "TPDO2 " + d.name, 8);
      }
      Add(&r, bus, "RPDO1 " + d.name, kActuatorRpdoLen);
    } else if (bus.fd) {
      Add(&r, bus, "TPDO1 " + d.name, kImuTpdoLen);
    } else {
      for (int i = 1; i <= 4; ++i) Add(&r, bus, "TPDO" + std::to_string(i) + " " + d.name, 8);
    }
    if (heartbeats) Add(&r, bus, "heartbeat " + d.name, kHeartbeatLen);
  }
  if (heartbeats) Add(&r, bus, "heartbeat master", kHeartbeatLen);  // the HAL's own
  r.load = cycle_period_s > 0.0 ? r.busy_time_s / cycle_period_s : 0.0;
  return r;
}

std::vector<BusLoadReport> CheckBusLoad(const HalConfig& config) {
  std::vector<BusLoadReport> reports;
  for (const BusConfig& bus : config.buses) {
    BusLoadReport r =
        ComputeBusLoad(bus, config.timing.cycle_period_s, config.heartbeats_in_worst_case);
    if (r.load > config.max_bus_load) {
      std::string rates = std::to_string(bus.nominal_bitrate / 1000) + " kbit/s";
      if (bus.fd) rates += " / " + std::to_string(bus.data_bitrate / 1000) + " kbit/s data (FD)";
      else rates += " (classic)";
      throw ConfigError("bus '" + bus.name + "': worst-case load " + Percent(r.load) + " (" +
                        std::to_string(r.items.size()) + " frames, " + Micros(r.busy_time_s) +
                        " per " + Micros(config.timing.cycle_period_s) + " cycle at " + rates +
                        ") exceeds the limit " + Percent(config.max_bus_load));
    }
    reports.push_back(std::move(r));
  }
  return reports;
}

}  // namespace hyq::hal
