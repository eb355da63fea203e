#include "hal/bus_load.h"

#include <gtest/gtest.h>

#include "hal/config_error.h"

namespace hyq::hal {
namespace {

TEST(BusLoad, ClassicFrameBitsMatchTheDesignFormula) {
  // 47 + 8n + floor((34 + 8n - 1) / 4)
  EXPECT_EQ(ClassicFrameBits(0), 55u);   // 47 + 0 + 8
  EXPECT_EQ(ClassicFrameBits(1), 65u);   // 47 + 8 + 10
  EXPECT_EQ(ClassicFrameBits(8), 135u);  // 47 + 64 + 24 (DESIGN §5)
}

TEST(BusLoad, FdFrameBitsHandComputed) {
  // nominal: 17 + 4 + 1 + 1 + 1 + 7 + 3 = 34 for every length
  // data:    5 + 8n + floor((21 + 8n)/4) - 4 + 4 + CRC + ceil((4 + CRC)/4)
  struct Case { std::uint32_t n, data; };
  const Case cases[] = {
      {1, 5 + 8 + (7 - 4) + 4 + 17 + 6},        // 43
      {8, 5 + 64 + (21 - 4) + 4 + 17 + 6},      // 113
      {16, 5 + 128 + (37 - 4) + 4 + 17 + 6},    // 193
      {32, 5 + 256 + (69 - 4) + 4 + 21 + 7},    // 358
      {64, 5 + 512 + (133 - 4) + 4 + 21 + 7}};  // 678
  for (const Case& c : cases) {
    const FdFrameBits b = FdFrameBitCount(c.n);
    EXPECT_EQ(b.nominal, 34u) << c.n;
    EXPECT_EQ(b.data, c.data) << c.n;
  }
  EXPECT_EQ(FdFrameBitCount(10).data, FdFrameBitCount(12).data) << "rounded up to an FD length";
}

TEST(BusLoad, FrameTimes) {
  EXPECT_NEAR(FrameTime_s(8, false, false, 1'000'000, 0), 135e-6, 1e-12);
  EXPECT_NEAR(FrameTime_s(16, true, true, 1'000'000, 5'000'000), 34e-6 + 193 / 5e6, 1e-12);
  EXPECT_NEAR(FrameTime_s(16, true, false, 1'000'000, 5'000'000), (34 + 193) * 1e-6, 1e-12);
}

TEST(BusLoad, DefaultLayoutHandComputed) {
  const HalConfig cfg = DefaultHalConfig();
  const std::vector<BusLoadReport> r = CheckBusLoad(cfg);
  ASSERT_EQ(r.size(), 4u);
  // per frame at 1/5 Mbit/s: 1 B 42.6 us, 8 B 56.6 us, 16 B 72.6 us, 32 B 105.6 us
  // lf: SYNC + 3 x (TPDO 16 + RPDO 8 + heartbeat) + IMU TPDO 32 + IMU heartbeat + the master's
  const double lf = 42.6 + 3 * (72.6 + 56.6 + 42.6) + 105.6 + 42.6 + 42.6;  // 748.8 us
  const double leg = 42.6 + 3 * (72.6 + 56.6 + 42.6) + 42.6;                // 600.6 us
  EXPECT_NEAR(r[0].busy_time_s * 1e6, lf, 1e-6);
  EXPECT_NEAR(r[0].load, lf / 1000.0, 1e-9);
  EXPECT_EQ(r[0].items.size(), 1u + 3 * 3 + 2 + 1);
  for (int b = 1; b < 4; ++b) EXPECT_NEAR(r[static_cast<std::size_t>(b)].busy_time_s * 1e6, leg, 1e-6);
}

TEST(BusLoad, DesignNumbersForClassicCan) {
  // DESIGN §5: one classic 1 Mbit/s bus per leg, one 8-byte TPDO and RPDO per joint and a SYNC
  // without data: 3 x (135 + 135) + 55 = 865 bits per 1 ms cycle = 86.5 %
  EXPECT_EQ(3 * (ClassicFrameBits(8) + ClassicFrameBits(8)) + ClassicFrameBits(0), 865u);
  // our data needs two classic TPDOs per actuator: the classic bus is refused, naming it
  HalConfig cfg = DefaultHalConfig();
  cfg.buses[0].fd = false;
  const BusLoadReport lf = ComputeBusLoad(cfg.buses[0], 0.001, true);
  // SYNC 65 + 3 x (2 x 135 + 135 + 65) + IMU 4 x 135 + 65 + master heartbeat 65 = 2145 bits
  EXPECT_NEAR(lf.busy_time_s * 1e6, 2145.0, 1e-6);
  try {
    (void)CheckBusLoad(cfg);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bus 'lf'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("214.5 %"), std::string::npos) << msg;
    EXPECT_NE(msg.find("limit 80.0 %"), std::string::npos) << msg;
    EXPECT_NE(msg.find("(classic)"), std::string::npos) << msg;
  }
}

TEST(BusLoad, LimitIsConfigurableAndNamesTheBus) {
  HalConfig cfg = DefaultHalConfig();
  cfg.max_bus_load = 0.74;  // lf carries the IMU: 74.9 %
  try {
    (void)CheckBusLoad(cfg);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bus 'lf': worst-case load 74.9 %"), std::string::npos) << msg;
    EXPECT_NE(msg.find("(13 frames, 748.8 us per 1000.0 us cycle at 1000 kbit/s / 5000 kbit/s "
                       "data (FD)) exceeds the limit 74.0 %"),
              std::string::npos) << msg;
  }
  cfg.max_bus_load = 0.75;
  EXPECT_NO_THROW((void)CheckBusLoad(cfg));
  // 2 Mbit/s data phase: lf 55.5 + 3 x (130.5 + 90.5 + 55.5) + 213 + 55.5 + 55.5 = 1209 us
  cfg = DefaultHalConfig();
  cfg.buses[0].data_bitrate = 2'000'000;
  EXPECT_NEAR(ComputeBusLoad(cfg.buses[0], 0.001, true).load, 1.209, 1e-9);
  EXPECT_THROW((void)CheckBusLoad(cfg), ConfigError);
  EXPECT_THROW(ValidateHalConfig(cfg), ConfigError);
}

}  // namespace
}  // namespace hyq::hal
