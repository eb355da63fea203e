#include "hal/protocol.h"

#include <gtest/gtest.h>

#include <limits>

namespace hyq::hal {
namespace {

TEST(Protocol, CobIdsFollowCanopen) {
  EXPECT_EQ(EncodeNmt(NmtCommand::kStart, 3).id, 0x000u);
  EXPECT_EQ(EncodeSync(1).id, 0x080u);
  EXPECT_EQ(EncodeEmcy(3, {}).id, 0x083u);
  EXPECT_EQ(EncodeActuatorTpdo(3, {}).id, 0x183u);
  EXPECT_EQ(EncodeActuatorRpdo(3, {}).id, 0x203u);
  EXPECT_EQ(EncodeImuTpdo(16, {}).id, 0x190u);
  EXPECT_EQ(EncodeHeartbeat(3, NmtState::kOperational).id, 0x703u);
}

TEST(Protocol, ClassifySplitsFunctionCodeAndNode) {
  struct Case { std::uint32_t id; FrameKind kind; std::uint8_t node; };
  const Case cases[] = {
      {0x000, FrameKind::kNmt, 0},      {0x080, FrameKind::kSync, 0},
      {0x081, FrameKind::kEmcy, 1},     {0x0FF, FrameKind::kEmcy, 127},
      {0x181, FrameKind::kTpdo1, 1},    {0x282, FrameKind::kTpdo2, 2},
      {0x383, FrameKind::kTpdo3, 3},    {0x484, FrameKind::kTpdo4, 4},
      {0x205, FrameKind::kRpdo1, 5},    {0x306, FrameKind::kRpdo2, 6},
      {0x407, FrameKind::kRpdo3, 7},    {0x508, FrameKind::kRpdo4, 8},
      {0x589, FrameKind::kSdoTx, 9},    {0x60A, FrameKind::kSdoRx, 10},
      {0x70B, FrameKind::kHeartbeat, 11}, {0x780, FrameKind::kUnknown, 0},
      {0x7FF, FrameKind::kUnknown, 0},  {0x180, FrameKind::kUnknown, 0},
      {0x800, FrameKind::kUnknown, 0},  {0xFFFFFFFF, FrameKind::kUnknown, 0}};
  for (const Case& c : cases) {
    const FrameAddress a = Classify(c.id);
    EXPECT_EQ(a.kind, c.kind) << std::hex << c.id;
    EXPECT_EQ(a.node, c.node) << std::hex << c.id;
  }
}

TEST(Protocol, ActuatorTpdoRoundTripAndLittleEndianLayout) {
  ActuatorTpdo p;
  p.position_counts = 0x01020304;
  p.velocity_counts_s = -123456;
  p.effort_counts = std::numeric_limits<std::int32_t>::min();
  p.status = status_bit::kReady | status_bit::kEnabled;
  p.sync_counter = 240;
  p.error_register = 0x81;
  const CanFrame f = EncodeActuatorTpdo(2, p);
  EXPECT_EQ(f.len, kActuatorTpdoLen);
  EXPECT_TRUE(f.is_fd());
  EXPECT_EQ(f.data[0], 0x04);
  EXPECT_EQ(f.data[3], 0x01);
  EXPECT_EQ(f.data[12], 0x03);
  EXPECT_EQ(f.data[14], 240);
  ActuatorTpdo q;
  ASSERT_EQ(DecodeActuatorTpdo(f, 2, &q), PdoStatus::kOk);
  EXPECT_EQ(q.position_counts, p.position_counts);
  EXPECT_EQ(q.velocity_counts_s, p.velocity_counts_s);
  EXPECT_EQ(q.effort_counts, p.effort_counts);
  EXPECT_EQ(q.status, p.status);
  EXPECT_EQ(q.sync_counter, p.sync_counter);
  EXPECT_EQ(q.error_register, p.error_register);
}

TEST(Protocol, RpdoImuEmcyNmtSyncHeartbeatRoundTrip) {
  ActuatorRpdo r{-150000, control_bit::kEnable | control_bit::kFaultReset, 17, 0};
  ActuatorRpdo r2;
  ASSERT_EQ(DecodeActuatorRpdo(EncodeActuatorRpdo(1, r), 1, &r2), PdoStatus::kOk);
  EXPECT_EQ(r2.torque_mNm, -150000);
  EXPECT_EQ(r2.control, r.control);
  EXPECT_EQ(r2.sync_counter, 17);

  ImuTpdo m;
  m.gyro_urad_s = {1, -2, 2147483647};
  m.accel_um_s2 = {-9810000, 0, 42};
  m.status = status_bit::kReady;
  m.sync_counter = 5;
  ImuTpdo m2;
  const CanFrame mf = EncodeImuTpdo(16, m);
  EXPECT_EQ(mf.len, kImuTpdoLen);
  ASSERT_EQ(DecodeImuTpdo(mf, 16, &m2), PdoStatus::kOk);
  EXPECT_EQ(m2.gyro_urad_s, m.gyro_urad_s);
  EXPECT_EQ(m2.accel_um_s2, m.accel_um_s2);
  EXPECT_EQ(m2.sync_counter, 5);

  EmcyMessage e{emcy::kSensor, 0x01, {1, 2, 3, 4, 5}}, e2;
  ASSERT_EQ(DecodeEmcy(EncodeEmcy(9, e), 9, &e2), PdoStatus::kOk);
  EXPECT_EQ(e2.code, emcy::kSensor);
  EXPECT_EQ(e2.vendor, e.vendor);

  NmtCommand cmd{};
  std::uint8_t node = 0;
  ASSERT_EQ(DecodeNmt(EncodeNmt(NmtCommand::kResetCommunication, 0), &cmd, &node), PdoStatus::kOk);
  EXPECT_EQ(cmd, NmtCommand::kResetCommunication);
  EXPECT_EQ(node, 0);

  std::uint8_t counter = 0;
  ASSERT_EQ(DecodeSync(EncodeSync(240), &counter), PdoStatus::kOk);
  EXPECT_EQ(counter, 240);

  NmtState st{};
  ASSERT_EQ(DecodeHeartbeat(EncodeHeartbeat(4, NmtState::kPreOperational), 4, &st), PdoStatus::kOk);
  EXPECT_EQ(st, NmtState::kPreOperational);
}

TEST(Protocol, MalformedFramesAreRejectedWithoutTouchingTheOutput) {
  const ActuatorTpdo sentinel{7, 7, 7, 7, 7, 7};
  ActuatorTpdo out = sentinel;
  CanFrame f = EncodeActuatorTpdo(2, ActuatorTpdo{1, 2, 3, 4, 5, 6});
  CanFrame g = f;
  g.len = 8;
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kWrongLength);
  g = f;
  g.flags |= CanFrame::kRemote;
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kNotData);
  g = f;
  g.flags |= CanFrame::kError;
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kNotData);
  g = f;
  g.flags |= CanFrame::kExtendedId;
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kExtendedId);
  EXPECT_EQ(DecodeActuatorTpdo(f, 3, &out), PdoStatus::kWrongId);
  EXPECT_EQ(DecodeActuatorTpdo(f, 0, &out), PdoStatus::kWrongId);
  g = f;
  g.data[14] = 0;  // SYNC counters run 1..240
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kBadValue);
  g.data[14] = 241;
  EXPECT_EQ(DecodeActuatorTpdo(g, 2, &out), PdoStatus::kBadValue);
  EXPECT_EQ(out.position_counts, sentinel.position_counts);

  NmtState st{};
  CanFrame hb = EncodeHeartbeat(4, NmtState::kOperational);
  hb.data[0] = 0x33;
  EXPECT_EQ(DecodeHeartbeat(hb, 4, &st), PdoStatus::kBadValue);
  NmtCommand cmd{};
  std::uint8_t node = 0;
  CanFrame nmt = EncodeNmt(NmtCommand::kStart, 1);
  nmt.data[0] = 0x55;
  EXPECT_EQ(DecodeNmt(nmt, &cmd, &node), PdoStatus::kBadValue);
  std::uint8_t counter = 0;
  CanFrame sync = EncodeSync(1);
  sync.len = 0;
  EXPECT_EQ(DecodeSync(sync, &counter), PdoStatus::kWrongLength);
}

// the simulated plant's clock (lock-step only): CiA 301's TIME id, two little-endian u32, and
// no node a device could own (the HAL would count it unknown, never as a device's frame)
TEST(Protocol, PlantClockRoundTripOnTheTimeId) {
  const CanFrame f = EncodePlantClock({0x01020304u, 19});
  EXPECT_EQ(f.id, 0x100u);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.data[0], 0x04);
  EXPECT_EQ(f.data[3], 0x01);
  EXPECT_EQ(f.data[4], 19);
  PlantClock c;
  ASSERT_EQ(DecodePlantClock(f, &c), PdoStatus::kOk);
  EXPECT_EQ(c.steps, 0x01020304u);
  EXPECT_EQ(c.stalled_steps, 19u);
  EXPECT_EQ(Classify(f.id).kind, FrameKind::kUnknown);
  CanFrame short_frame = f;
  short_frame.len = 4;
  EXPECT_EQ(DecodePlantClock(short_frame, &c), PdoStatus::kWrongLength);
  EXPECT_EQ(DecodePlantClock(EncodeSync(1), &c), PdoStatus::kWrongId);
}

TEST(Protocol, SyncCounterWrapsAt240) {
  EXPECT_EQ(NextSyncCounter(0), 1);
  EXPECT_EQ(NextSyncCounter(1), 2);
  EXPECT_EQ(NextSyncCounter(239), 240);
  EXPECT_EQ(NextSyncCounter(240), 1);
}

}  // namespace
}  // namespace hyq::hal
