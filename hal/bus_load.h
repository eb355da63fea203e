// Worst-case bus load of one SYNC cycle (docs/can_protocol.md §Bus layout, docs/hal.md).
//
// Classic CAN, 11-bit identifier, n data bytes, worst-case bit stuffing [Davis et al. 2007]:
//   bits = 47 + 8n + floor((34 + 8n - 1) / 4)                                       (1)
// CAN FD, 11-bit identifier (FBFF), bit-rate switch, n data bytes, worst-case stuffing (derived
// in docs/can_protocol.md):
//   nominal-rate bits = 34 = SOF..BRS 17 + their worst-case stuff bits 4 + CRC delimiter 1
//                          + ACK 1 + ACK delimiter 1 + EOF 7 + IFS 3                    (2)
//   data-rate bits    = ESI 1 + DLC 4 + 8n + floor((21 + 8n) / 4) - 4
//                          + stuff count 4 + CRC (17 if n <= 16 else 21)
//                          + fixed stuff bits ceil((4 + CRC) / 4)                        (3)
//   time = nominal bits / nominal bit rate + data bits / data bit rate
// Without bit-rate switch both parts run at the nominal rate.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/hal_config.h"

namespace hyq::hal {

/// Eq. (1).
std::uint32_t ClassicFrameBits(std::uint32_t data_bytes) noexcept;

struct FdFrameBits {
  std::uint32_t nominal = 0;  // eq. (2)
  std::uint32_t data = 0;     // eq. (3)
};
/// Eqs. (2)-(3); data_bytes must be a valid FD length (it is rounded up to one otherwise).
FdFrameBits FdFrameBitCount(std::uint32_t data_bytes) noexcept;

/// One frame the layout sends in the worst-case cycle.
struct LoadItem {
  std::string what;        // "SYNC", "TPDO1 lf_haa", ...
  std::uint32_t data_bytes = 0;
  bool fd = false;
  bool bitrate_switch = false;
  double time_s = 0.0;     // time on the wire at the bus's bit rates
};

struct BusLoadReport {
  std::string bus;
  double cycle_period_s = 0.0;
  double busy_time_s = 0.0;  // sum of the items' wire times
  double load = 0.0;         // busy_time_s / cycle_period_s (1.0 = 100 %)
  std::vector<LoadItem> items;
};

/// Wire time of one frame at the given bit rates.
double FrameTime_s(std::uint32_t data_bytes, bool fd, bool bitrate_switch,
                   std::uint32_t nominal_bitrate, std::uint32_t data_bitrate) noexcept;

/// The worst-case cycle of `bus` under the HyQ protocol: SYNC, every device's TPDO(s), every
/// actuator's RPDO and, when `heartbeats` is set, every device's heartbeat in the same cycle.
/// On an FD bus all frames are FD with bit-rate switch (actuator TPDO 16 B, RPDO 8 B, IMU TPDO
/// 32 B, SYNC and heartbeat 1 B). A classic bus needs the classic split of the same data: two
/// 8-byte TPDOs per actuator, four per IMU, one RPDO, all at the nominal rate.
BusLoadReport ComputeBusLoad(const BusConfig& bus, double cycle_period_s, bool heartbeats);

/// Throws ConfigError naming the bus, its load, the limit and the bit rates when any bus of
/// `config` exceeds config.max_bus_load; returns every bus's report otherwise.
std::vector<BusLoadReport> CheckBusLoad(const HalConfig& config);

}  // namespace hyq::hal
