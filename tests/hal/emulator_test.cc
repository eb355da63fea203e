// The device emulator on its own, driven by a hand-written master on a loopback endpoint.
#include "hal/emulator.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "hal/loopback_bus.h"
#include "tests/hal/hal_fixture.h"

namespace hyq::hal {
namespace {

class EmulatorAlone : public ::testing::Test {
 protected:
  EmulatorAlone() : config_(DefaultHalConfig()) {
    for (const BusConfig& b : config_.buses) {
      wires_.push_back(std::make_unique<LoopbackBus>(b.name, 2, 256, true));
      devices_.push_back(&wires_.back()->endpoint(1));
    }
    emu_ = std::make_unique<Emulator>(config_, devices_);
  }
  LoopbackEndpoint& master() { return wires_[1]->endpoint(0); }  // bus rf: nodes 1, 2, 3
  void Send(const CanFrame& f) {
    std::size_t sent = 0;
    ASSERT_EQ(master().Send({&f, 1}, &sent), CanStatus::kOk);
  }
  std::vector<CanFrame> Poll() {
    emu_->Poll(now_);
    now_ += 1'000'000;
    std::vector<CanFrame> out;
    std::array<CanFrame, 64> rx;
    std::size_t n = 0;
    (void)master().Receive(rx, &n);
    out.assign(rx.begin(), rx.begin() + static_cast<std::ptrdiff_t>(n));
    return out;
  }
  static const CanFrame* Find(const std::vector<CanFrame>& v, std::uint32_t id) {
    for (const CanFrame& f : v)
      if (f.id == id) return &f;
    return nullptr;
  }

  HalConfig config_;
  std::vector<std::unique_ptr<LoopbackBus>> wires_;
  std::vector<CanChannel*> devices_;
  std::unique_ptr<Emulator> emu_;
  std::int64_t now_ = 1'000'000'000;
};

TEST_F(EmulatorAlone, AnswersNmtSyncAndRpdo) {
  // power-on: boot-up from each board
  std::vector<CanFrame> rx = Poll();
  for (std::uint32_t n = 1; n <= 3; ++n) {
    const CanFrame* f = Find(rx, 0x700 + n);
    ASSERT_NE(f, nullptr) << n;
    EXPECT_EQ(f->data[0], 0x00);
  }
  // pre-operational: SYNC is not answered
  Send(EncodeSync(1));
  EXPECT_EQ(Find(Poll(), 0x181), nullptr);
  // start node 2 only
  Send(EncodeNmt(NmtCommand::kStart, 2));
  Send(EncodeSync(2));
  rx = Poll();
  EXPECT_EQ(Find(rx, 0x181), nullptr);
  ASSERT_NE(Find(rx, 0x182), nullptr);
  ActuatorTpdo p;
  ASSERT_EQ(DecodeActuatorTpdo(*Find(rx, 0x182), 2, &p), PdoStatus::kOk);
  EXPECT_EQ(p.sync_counter, 2);
  EXPECT_EQ(p.status & status_bit::kEnabled, 0);
  EXPECT_EQ(emu_->nmt_state(4), NmtState::kOperational);  // rf_hfe
  // enable with a set-point
  Send(EncodeActuatorRpdo(2, {12345, control_bit::kEnable, 3, 0}));
  Send(EncodeSync(3));
  rx = Poll();
  ASSERT_EQ(DecodeActuatorTpdo(*Find(rx, 0x182), 2, &p), PdoStatus::kOk);
  EXPECT_NE(p.status & status_bit::kEnabled, 0);
  EXPECT_TRUE(emu_->outputs_enabled(4));
  EXPECT_NEAR(emu_->torque_setpoint_Nm(4), 12.345, 1e-12);
  EXPECT_EQ(emu_->rpdos_received(4), 1u);
}

TEST_F(EmulatorAlone, RpdoWatchdogMalformedRpdoStopAndBusOff) {
  (void)Poll();
  Send(EncodeNmt(NmtCommand::kStart, 0));
  Send(EncodeActuatorRpdo(1, {1000, control_bit::kEnable, 1, 0}));
  Send(EncodeSync(1));
  (void)Poll();
  EXPECT_TRUE(emu_->outputs_enabled(3));
  // three SYNCs without a set-point: outputs off, status bit, EMCY 0x8250
  std::vector<CanFrame> rx;
  for (std::uint8_t c = 2; c <= 4; ++c) {
    Send(EncodeSync(c));
    rx = Poll();
  }
  EXPECT_FALSE(emu_->outputs_enabled(3));
  EXPECT_EQ(emu_->torque_setpoint_Nm(3), 0.0);
  const CanFrame* e = Find(rx, 0x081);
  ASSERT_NE(e, nullptr);
  EmcyMessage m;
  ASSERT_EQ(DecodeEmcy(*e, 1, &m), PdoStatus::kOk);
  EXPECT_EQ(m.code, emcy::kRpdoTimeout);
  ActuatorTpdo p;
  ASSERT_EQ(DecodeActuatorTpdo(*Find(rx, 0x181), 1, &p), PdoStatus::kOk);
  EXPECT_NE(p.status & status_bit::kRpdoWatchdog, 0);
  // a malformed RPDO: EMCY 0x8210
  CanFrame bad = EncodeActuatorRpdo(2, {});
  bad.len = 4;
  Send(bad);
  rx = Poll();
  ASSERT_NE(Find(rx, 0x082), nullptr);
  ASSERT_EQ(DecodeEmcy(*Find(rx, 0x082), 2, &m), PdoStatus::kOk);
  EXPECT_EQ(m.code, emcy::kPdoLength);
  EXPECT_EQ(emu_->counters(1).malformed_rx, 1u);
  // NMT stop: no more TPDOs
  Send(EncodeNmt(NmtCommand::kStop, 0));
  Send(EncodeSync(5));
  EXPECT_EQ(Find(Poll(), 0x181), nullptr);
  // bus-off: silent; recovery: EMCY 0x8140 from every board
  Send(EncodeNmt(NmtCommand::kStart, 0));
  (void)Poll();
  emu_->SetBusOff(1, true);
  Send(EncodeSync(6));
  EXPECT_TRUE(Poll().empty());
  emu_->SetBusOff(1, false);
  rx = Poll();
  for (std::uint32_t n = 1; n <= 3; ++n) {
    ASSERT_NE(Find(rx, 0x080 + n), nullptr) << n;
    ASSERT_EQ(DecodeEmcy(*Find(rx, 0x080 + n), static_cast<std::uint8_t>(n), &m), PdoStatus::kOk);
    EXPECT_EQ(m.code, emcy::kBusOffRecovered);
  }
}

// Behind after a stall of its host, an emulator told to answer only the newest SYNC sends one
// TPDO per board, echoing the newest counter; the older SYNCs still count for the RPDO watchdog.
// Without the setting (the default) every SYNC is answered, as on the wire.
TEST_F(EmulatorAlone, BehindItAnswersOnlyTheNewestSyncWhenToldTo) {
  (void)Poll();
  Send(EncodeNmt(NmtCommand::kStart, 0));
  Send(EncodeActuatorRpdo(1, {1000, control_bit::kEnable, 1, 0}));
  Send(EncodeSync(1));
  (void)Poll();
  ASSERT_TRUE(emu_->outputs_enabled(3));
  const auto answers = [&](const std::vector<CanFrame>& rx, std::uint32_t id) {
    std::vector<int> counters;
    for (const CanFrame& f : rx)
      if (f.id == id) counters.push_back(TpdoSyncCounter(f));
    return counters;
  };
  // three SYNCs waiting, by default: three answers per board, oldest first
  for (std::uint8_t c = 2; c <= 4; ++c) Send(EncodeSync(c));
  std::vector<CanFrame> rx = Poll();
  EXPECT_EQ(answers(rx, 0x182), (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(emu_->counters(1).superseded_syncs, 0u);
  // told to answer the newest only: one answer per board, the newest counter
  emu_->SetAnswerNewestSyncOnly(true);
  Send(EncodeNmt(NmtCommand::kStart, 0));
  Send(EncodeActuatorRpdo(1, {1000, control_bit::kEnable, 5, 0}));
  Send(EncodeSync(5));
  (void)Poll();
  ASSERT_TRUE(emu_->outputs_enabled(3));
  for (std::uint8_t c = 6; c <= 8; ++c) Send(EncodeSync(c));
  rx = Poll();
  for (std::uint32_t node = 1; node <= 3; ++node)
    EXPECT_EQ(answers(rx, 0x180 + node), (std::vector<int>{8})) << node;
  EXPECT_EQ(emu_->counters(1).superseded_syncs, 2u);
  EXPECT_EQ(emu_->counters(1).syncs, 8u);
  // the unanswered SYNCs still counted: three without a set-point tripped the RPDO watchdog
  EXPECT_FALSE(emu_->outputs_enabled(3));
  ActuatorTpdo p;
  ASSERT_NE(Find(rx, 0x181), nullptr);
  ASSERT_EQ(DecodeActuatorTpdo(*Find(rx, 0x181), 1, &p), PdoStatus::kOk);
  EXPECT_NE(p.status & status_bit::kRpdoWatchdog, 0);
  // one SYNC at a time: each answered
  Send(EncodeSync(9));
  EXPECT_EQ(answers(Poll(), 0x182), (std::vector<int>{9}));
  EXPECT_EQ(emu_->counters(1).superseded_syncs, 2u);
}

// A master that dies sends nothing more, not even SYNCs, so a SYNC-counting watchdog never
// fires: the boards' own timer does, within device_setpoint_timeout_s (+ one poll period).
TEST_F(EmulatorAlone, DeadMasterTripsTheBoardsOnTheirOwnTimer) {
  ASSERT_DOUBLE_EQ(config_.timing.device_setpoint_timeout_s, 0.008);
  (void)Poll();
  Send(EncodeNmt(NmtCommand::kStart, 0));
  Send(EncodeActuatorRpdo(1, {50'900, control_bit::kEnable, 1, 0}));  // 50.9 N·m on a knee
  Send(EncodeSync(1));
  (void)Poll();
  ASSERT_TRUE(emu_->outputs_enabled(3));
  ASSERT_DOUBLE_EQ(emu_->torque_setpoint_Nm(3), 50.9);
  std::vector<CanFrame> rx;
  int polls = 0;
  while (emu_->outputs_enabled(3) && polls < 100) {  // silence from here on: no SYNC, no RPDO
    rx = Poll();
    ++polls;
  }
  EXPECT_EQ(polls, 9);  // 1 ms per poll: tripped 9 ms after the last set-point (> 8 ms)
  EXPECT_EQ(emu_->torque_setpoint_Nm(3), 0.0);
  EXPECT_EQ(emu_->nmt_state(3), NmtState::kPreOperational);  // out of OP
  EXPECT_EQ(emu_->setpoint_trip_delay_ns(3), 9'000'000);
  EXPECT_LE(emu_->setpoint_trip_delay_ns(3), 10'000'000);
  const CanFrame* e = Find(rx, 0x081);
  ASSERT_NE(e, nullptr);
  EmcyMessage m;
  ASSERT_EQ(DecodeEmcy(*e, 1, &m), PdoStatus::kOk);
  EXPECT_EQ(m.code, emcy::kRpdoTimeout);
  // the other boards of the bus (outputs off, but in OP without SYNCs) left OP too
  EXPECT_EQ(emu_->nmt_state(4), NmtState::kPreOperational);
  EXPECT_EQ(emu_->counters(1).setpoint_timeouts, 3u);
}

// CiA 301 heartbeat consumer of the master (a board must drop its torque when the master is gone): SYNCs and set-points keep
// coming, but the master's heartbeat stops: 200 ms later the board is at 0 N·m, out of OP, with
// EMCY 0x8130. Before the first heartbeat the consumer is not active.
TEST_F(EmulatorAlone, MasterHeartbeatConsumerTripsWhenTheHeartbeatStops) {
  ASSERT_DOUBLE_EQ(config_.timing.master_heartbeat_timeout_s, 0.2);
  const CanFrame heartbeat = EncodeHeartbeat(kMasterNodeId, NmtState::kOperational);
  EXPECT_EQ(heartbeat.id, 0x77Fu);
  (void)Poll();
  Send(EncodeNmt(NmtCommand::kStart, 0));
  std::uint8_t sync = 0;
  const auto cycle = [&] {
    sync = static_cast<std::uint8_t>(sync % 240 + 1);
    Send(EncodeActuatorRpdo(1, {20'000, control_bit::kEnable, sync, 0}));
    Send(EncodeSync(sync));
    return Poll();
  };
  // no heartbeat at all for 500 ms: the consumer is not active yet, nothing trips
  for (int i = 0; i < 500; ++i) (void)cycle();
  ASSERT_TRUE(emu_->outputs_enabled(3));
  EXPECT_EQ(emu_->counters(1).heartbeat_trips, 0u);
  // a heartbeat every 50 ms for 1 s: still fine
  for (int i = 0; i < 1000; ++i) {
    if (i % 50 == 0) Send(heartbeat);
    (void)cycle();
  }
  ASSERT_TRUE(emu_->outputs_enabled(3));
  EXPECT_EQ(emu_->counters(1).master_heartbeats, 20u);
  // the heartbeat stops (the last one was 50 ms ago): the board trips once 200 ms have passed
  std::vector<CanFrame> rx;
  int polls = 0;
  while (emu_->outputs_enabled(3) && polls < 1000) {
    rx = cycle();
    ++polls;
  }
  // the last heartbeat arrived with poll 950 of 1000: 49 + 152 = 201 ms of polls (> 200 ms)
  EXPECT_EQ(polls, 152);
  EXPECT_EQ(emu_->torque_setpoint_Nm(3), 0.0);
  EXPECT_EQ(emu_->nmt_state(3), NmtState::kPreOperational);
  const CanFrame* e = Find(rx, 0x081);
  ASSERT_NE(e, nullptr);
  EmcyMessage m;
  ASSERT_EQ(DecodeEmcy(*e, 1, &m), PdoStatus::kOk);
  EXPECT_EQ(m.code, emcy::kHeartbeatLost);
  EXPECT_EQ(emu_->counters(1).heartbeat_trips, 3u);
  EXPECT_EQ(emu_->counters(1).setpoint_timeouts, 0u);  // not the set-point timer: it had SYNCs
}

// The HAL sends that heartbeat (every 50 ms on every bus), and one it did not send is a second
// master.
TEST(EmulatorWithHal, TheHalSendsTheMasterHeartbeatAndSeesASpoofedOne) {
  testing::HalRig rig(DefaultHalConfig(), 1, /*endpoints=*/3);
  rig.BringUp();
  std::array<std::uint64_t, 4> before{};
  for (int b = 0; b < 4; ++b) before[static_cast<std::size_t>(b)] = rig.emu->counters(b).master_heartbeats;
  rig.Steps(1000);
  for (int b = 0; b < 4; ++b) {
    EXPECT_EQ(rig.emu->counters(b).master_heartbeats - before[static_cast<std::size_t>(b)], 20u) << b;
    EXPECT_EQ(rig.emu->counters(b).heartbeat_trips, 0u);
  }
  EXPECT_TRUE(rig.hal->AllIn(DeviceState::kOp));
  EXPECT_EQ(rig.hal->bus(2).counters().foreign_master, 0u);
  const CanFrame spoof = EncodeHeartbeat(kMasterNodeId, NmtState::kOperational);
  std::size_t sent = 0;
  ASSERT_EQ(rig.wires[2]->endpoint(2).Send({&spoof, 1}, &sent), CanStatus::kOk);
  (void)rig.Step();
  EXPECT_EQ(rig.hal->bus(2).counters().foreign_master, 1u);
  EXPECT_EQ(rig.hal->bus(2).counters().last_foreign_id, 0x77Fu);
}

TEST(EmulatorWithHal, RandomDropsAreCountedOneForOneOverManyCycles) {
  testing::HalRig rig(DefaultHalConfig(), /*seed=*/12345);
  rig.BringUp();
  for (int j = 0; j < kNumJoints; ++j) rig.emu->joint_faults(j).drop_probability = 0.01;
  rig.emu->imu_faults().drop_probability = 0.01;
  for (int i = 0; i < 3000; ++i) (void)rig.Step();  // > 12 wraps of the SYNC counter
  (void)rig.hal->Read(rig.now_ns);                  // the answers to the last SYNC
  std::uint64_t dropped = 0, missing = 0, late = 0, malformed = 0;
  for (std::size_t b = 0; b < rig.hal->num_buses(); ++b) {
    dropped += rig.emu->counters(static_cast<int>(b)).dropped;
    missing += rig.hal->bus(b).counters().missing;
    late += rig.hal->bus(b).counters().late;
    malformed += rig.hal->bus(b).counters().malformed;
  }
  EXPECT_GT(dropped, 200u);
  EXPECT_EQ(missing, dropped) << "every dropped TPDO is exactly one missing input";
  EXPECT_EQ(late + malformed, 0u);
  EXPECT_TRUE(rig.hal->AllIn(DeviceState::kOp)) << rig.hal->BringUpReport(rig.now_ns);
}

TEST(EmulatorWithHal, BrokenSensorReportsAnInvalidCountAndTheSensorFaultBit) {
  testing::HalRig rig(DefaultHalConfig());
  rig.BringUp();
  const int j = 4;  // rf_hfe: a cylinder with a load cell
  rig.emu->SetJointState(j, 0.3, 0.0, 20.0);
  (void)rig.Step();
  (void)rig.Step();
  EXPECT_NEAR(rig.hal->image().joints[j].torque_Nm, 20.0, 0.05);
  rig.emu->joint_faults(j).sensor_fault = true;
  rig.emu->imu_faults().sensor_fault = true;
  (void)rig.Step();
  (void)rig.Step();
  const JointInput& in = rig.hal->image().joints[j];
  EXPECT_EQ(in.effort_counts, kInvalidSensorCounts);
  EXPECT_NE(in.status_word & status_bit::kSensorFault, 0);
  EXPECT_GT(std::abs(in.sensor_value), 5000.0) << "outside the load cell's +-5 kN";
  EXPECT_NE(rig.hal->image().imu.status_word & status_bit::kSensorFault, 0);
  // with the EMCY a real board sends, the HAL sees a device fault and leaves OP
  rig.emu->SendJointEmcy(j, emcy::kSensor);
  for (int i = 0; i < 3; ++i) (void)rig.Step();
  EXPECT_EQ(rig.hal->image().joints[j].status, InputStatus::kDeviceFault);
  EXPECT_EQ(rig.hal->bus(1).counters().last_emcy_code, emcy::kSensor);
  EXPECT_NE(rig.hal->image().joints[j].device_state, DeviceState::kOp);
  // the other joints are unaffected
  EXPECT_EQ(rig.hal->image().joints[0].status, InputStatus::kValid);
}

}  // namespace
}  // namespace hyq::hal
