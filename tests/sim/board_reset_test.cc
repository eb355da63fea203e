// A board that resets and boots again (hyq-sim --fault T:reset:DEVICE[:BOOT_S]): the emulated
// board on its own, driven by a hand-written master (outputs off at once, silent for its boot
// time, the boot-up message, PRE-OPERATIONAL with nothing latched, answering NMT again), and the
// simulated robot's reset seen through the HAL (what the master's device state machine makes of
// it: the board leaves OP, and after its boot-up it comes back to SAFE-OP and waits there for an
// acknowledgement).
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

#include "hal/emulator.h"
#include "hal/loopback_bus.h"
#include "hal/protocol.h"
#include "sim/fault_spec.h"
#include "tests/hil/hil_rig.h"

namespace hyq::sim {
namespace {

using hal::CanFrame;
using hal::DeviceError;
using hal::DeviceState;
using hal::NmtCommand;
using hal::NmtState;

constexpr std::int64_t kMs = 1'000'000;
constexpr int kLfKfe = 2;      // joint index, node 3 on bus lf
constexpr std::uint8_t kNode = 3;
constexpr std::uint8_t kImuNode = 16;

// the emulator on the configured buses, a master of our own on bus lf
class ResetBoard : public ::testing::Test {
 protected:
  ResetBoard() : config_(testing::HilHalConfig()) {
    for (const hal::BusConfig& b : config_.buses) {
      wires_.push_back(std::make_unique<hal::LoopbackBus>(b.name, 2, 256, true));
      devices_.push_back(&wires_.back()->endpoint(1));
    }
    emu_ = std::make_unique<hal::Emulator>(config_, devices_);
  }
  void Send(const CanFrame& f) {
    std::size_t sent = 0;
    ASSERT_EQ(wires_[0]->endpoint(0).Send({&f, 1}, &sent), hal::CanStatus::kOk);
  }
  // one Poll at now_, then now_ += 1 ms; the frames bus lf carried back
  std::vector<CanFrame> Poll() {
    emu_->Poll(now_);
    now_ += kMs;
    std::array<CanFrame, 64> rx;
    std::size_t n = 0;
    (void)wires_[0]->endpoint(0).Receive(rx, &n);
    return {rx.begin(), rx.begin() + static_cast<std::ptrdiff_t>(n)};
  }
  static int Count(const std::vector<CanFrame>& v, std::uint8_t node) {
    int n = 0;
    for (const CanFrame& f : v) n += (f.id & 0x7Fu) == node ? 1 : 0;
    return n;
  }
  static const CanFrame* Find(const std::vector<CanFrame>& v, std::uint32_t id) {
    for (const CanFrame& f : v)
      if (f.id == id) return &f;
    return nullptr;
  }
  // every board of bus lf in OPERATIONAL, lf_kfe enabled with 12.345 N·m
  void Operate() {
    (void)Poll();  // power-on boot-ups
    Send(hal::EncodeNmt(NmtCommand::kStart, 0));
    Send(hal::EncodeActuatorRpdo(kNode, {12345, hal::control_bit::kEnable, 1, 0}));
    Send(hal::EncodeSync(1));
    (void)Poll();
    ASSERT_TRUE(emu_->outputs_enabled(kLfKfe));
    ASSERT_NEAR(emu_->torque_setpoint_Nm(kLfKfe), 12.345, 1e-12);
  }

  hal::HalConfig config_;
  std::vector<std::unique_ptr<hal::LoopbackBus>> wires_;
  std::vector<hal::CanChannel*> devices_;
  std::unique_ptr<hal::Emulator> emu_;
  std::int64_t now_ = 1'000'000'000;
};

TEST_F(ResetBoard, OutputsOffAtOnceSilentForTheBootTimeThenBootsIntoPreOp) {
  Operate();
  // latches a reset must clear: a fault (EMCY) the master has not acknowledged
  emu_->SendJointEmcy(kLfKfe, hal::emcy::kSupplyPressure);
  (void)Poll();
  emu_->ResetJointBoard(kLfKfe, 5 * kMs);
  EXPECT_FALSE(emu_->outputs_enabled(kLfKfe));
  EXPECT_EQ(emu_->torque_setpoint_Nm(kLfKfe), 0.0);
  EXPECT_TRUE(emu_->booting(kLfKfe));
  EXPECT_EQ(emu_->counters(0).resets, 1u);
  // booting: nothing from it, whatever the master sends (SYNC, set-points, NMT); its neighbours
  // answer as before
  std::uint8_t counter = 2;
  for (int i = 0; i < 4; ++i, ++counter) {
    Send(hal::EncodeNmt(NmtCommand::kStart, kNode));
    Send(hal::EncodeActuatorRpdo(kNode, {5000, hal::control_bit::kEnable, counter, 0}));
    Send(hal::EncodeSync(counter));
    const std::vector<CanFrame> rx = Poll();
    EXPECT_EQ(Count(rx, kNode), 0) << i;
    EXPECT_NE(Find(rx, hal::cob::kTpdo1 + 1), nullptr) << i;
    EXPECT_FALSE(emu_->outputs_enabled(kLfKfe)) << i;
  }
  // 5 ms after the reset: the boot-up message, and PRE-OPERATIONAL
  Send(hal::EncodeSync(counter));
  std::vector<CanFrame> rx = Poll();
  EXPECT_FALSE(emu_->booting(kLfKfe));
  const CanFrame* boot = Find(rx, hal::cob::kHeartbeat + kNode);
  ASSERT_NE(boot, nullptr);
  NmtState st{};
  ASSERT_EQ(hal::DecodeHeartbeat(*boot, kNode, &st), hal::PdoStatus::kOk);
  EXPECT_EQ(st, NmtState::kBootUp);
  EXPECT_EQ(Count(rx, kNode), 1);  // no TPDO: not operational; no EMCY: nothing owed
  EXPECT_EQ(emu_->nmt_state(kLfKfe), NmtState::kPreOperational);
  // answering NMT again: started, it answers SYNCs with nothing latched, and a set-point with
  // enable is applied without a fault reset
  Send(hal::EncodeNmt(NmtCommand::kStart, kNode));
  Send(hal::EncodeSync(++counter));
  rx = Poll();
  const CanFrame* tpdo = Find(rx, hal::cob::kTpdo1 + kNode);
  ASSERT_NE(tpdo, nullptr);
  hal::ActuatorTpdo p;
  ASSERT_EQ(hal::DecodeActuatorTpdo(*tpdo, kNode, &p), hal::PdoStatus::kOk);
  EXPECT_EQ(p.status & (hal::status_bit::kFault | hal::status_bit::kRpdoWatchdog |
                        hal::status_bit::kEnabled), 0);
  EXPECT_EQ(p.error_register, 0);
  Send(hal::EncodeActuatorRpdo(kNode, {2000, hal::control_bit::kEnable, ++counter, 0}));
  Send(hal::EncodeSync(counter));
  (void)Poll();
  EXPECT_TRUE(emu_->outputs_enabled(kLfKfe));
  EXPECT_NEAR(emu_->torque_setpoint_Nm(kLfKfe), 2.0, 1e-12);
}

TEST_F(ResetBoard, TheImuBootsAgainAndAZeroBootTimeAnnouncesAtTheNextPoll) {
  Operate();
  emu_->ResetImu(0);
  std::vector<CanFrame> rx = Poll();
  const CanFrame* boot = Find(rx, hal::cob::kHeartbeat + kImuNode);
  ASSERT_NE(boot, nullptr);
  EXPECT_EQ(boot->data[0], 0x00);
  Send(hal::EncodeSync(2));
  EXPECT_EQ(Find(Poll(), hal::cob::kTpdo1 + kImuNode), nullptr);  // PRE-OPERATIONAL
  emu_->ResetJointBoard(kLfKfe, 0);
  EXPECT_FALSE(emu_->outputs_enabled(kLfKfe));
  rx = Poll();
  ASSERT_NE(Find(rx, hal::cob::kHeartbeat + kNode), nullptr);
  EXPECT_EQ(emu_->nmt_state(kLfKfe), NmtState::kPreOperational);
  EXPECT_EQ(emu_->counters(0).resets, 2u);
}

// the states a device passes through (consecutive repeats dropped) and its errors
struct Trace {
  std::vector<DeviceState> states;
  std::vector<DeviceError> errors;
  void Add(const hal::DeviceRuntime& d) {
    if (states.empty() || states.back() != d.state) states.push_back(d.state);
    if (d.error != DeviceError::kNone && (errors.empty() || errors.back() != d.error))
      errors.push_back(d.error);
  }
};

const hal::DeviceRuntime& LfKfe(const hal::Hal& hal) {
  for (const hal::DeviceRuntime& d : hal.bus(0).devices())
    if (d.joint == kLfKfe) return d;
  throw std::logic_error("no lf_kfe");
}

auto Pd() {
  return [](hal::ProcessImage& im) { testing::StandingPd(testing::HilModel(), im); };
}

// The HAL's view of a reset with the default boot time (50 ms): inputs lost (SAFE-OP, latched,
// then PRE-OP as they stay missing), the boot-up in PRE-OP, NMT start, SAFE-OP at its first
// inputs and no further until the master acknowledges; then OP.
TEST(ResetThroughTheHal, TheBoardLeavesOpComesBackToSafeOpAndWaitsForTheAcknowledgement) {
  testing::LoopbackRig rig;
  rig.robot->ScheduleFault(ParseFaultSpec("0.3:reset:lf_kfe", rig.cfg));
  rig.BringUp();
  while (rig.robot->time_s() < 0.3) (void)rig.Cycle(Pd());
  Trace t;
  t.Add(LfKfe(*rig.hal));
  ASSERT_EQ(t.states.back(), DeviceState::kOp);
  double safe_op_again_s = -1;
  while (rig.robot->time_s() < 0.6) {
    (void)rig.Cycle(Pd());
    t.Add(LfKfe(*rig.hal));
    if (safe_op_again_s < 0 && t.states.size() > 3 && t.states.back() == DeviceState::kSafeOp)
      safe_op_again_s = rig.robot->time_s();
  }
  EXPECT_EQ(t.states, (std::vector<DeviceState>{DeviceState::kOp, DeviceState::kSafeOp,
                                                DeviceState::kPreOp, DeviceState::kSafeOp}));
  EXPECT_EQ(t.errors, (std::vector<DeviceError>{DeviceError::kInputsLost}));
  EXPECT_EQ(LfKfe(*rig.hal).first_error, DeviceError::kInputsLost);
  EXPECT_TRUE(LfKfe(*rig.hal).error_latched);
  // back within a few cycles of the boot-up (0.35 s): NMT start, first inputs
  EXPECT_GT(safe_op_again_s, 0.35);
  EXPECT_LT(safe_op_again_s, 0.36);
  rig.hal->AcknowledgeFaults(rig.now());
  for (int i = 0; i < 20; ++i) (void)rig.Cycle(Pd());
  EXPECT_EQ(LfKfe(*rig.hal).state, DeviceState::kOp);
  EXPECT_TRUE(rig.robot->emulator().outputs_enabled(kLfKfe));
}

// A boot faster than the HAL's hold of a missing input (max_held_cycles): the master sees the
// boot-up while the device is still in OP, an unexpected reset (INIT), resets it once more and
// brings it back to SAFE-OP, latched.
TEST(ResetThroughTheHal, ABootUpInOpIsAnUnexpectedReset) {
  testing::LoopbackRig rig;
  rig.robot->ScheduleFault(ParseFaultSpec("0.3:reset:lf_kfe:0.001", rig.cfg));
  rig.BringUp();
  while (rig.robot->time_s() < 0.3) (void)rig.Cycle(Pd());
  Trace t;
  t.Add(LfKfe(*rig.hal));
  while (rig.robot->time_s() < 0.4) {
    (void)rig.Cycle(Pd());
    t.Add(LfKfe(*rig.hal));
  }
  ASSERT_GE(t.states.size(), 3u);
  EXPECT_EQ(t.states[1], DeviceState::kInit);
  EXPECT_EQ(t.states.back(), DeviceState::kSafeOp);
  ASSERT_FALSE(t.errors.empty());
  EXPECT_EQ(t.errors.front(), DeviceError::kUnexpectedReset);
  EXPECT_TRUE(LfKfe(*rig.hal).error_latched);
}

}  // namespace
}  // namespace hyq::sim
