// The device state machine driven by hand: events and cycles, no bus.
#include "hal/device_state_machine.h"

#include <gtest/gtest.h>

#include <array>

namespace hyq::hal {
namespace {

constexpr std::int64_t kMs = 1'000'000;

class StateMachine : public ::testing::Test {
 protected:
  StateMachine() {
    timing_.state_timeout_ns = 100 * kMs;
    timing_.heartbeat_timeout_ns = 300 * kMs;
    timing_.max_held_cycles = 3;
    timing_.min_valid_cycles_for_op = 2;
    queue_.frames = frames_.data();
    queue_.capacity = frames_.size();
    ctx_.timing = &timing_;
    ctx_.tx = &queue_;
    d_.node = 5;
    d_.kind = DeviceKind::kActuator;
  }
  void Cycle(std::int64_t dt = kMs) {
    ctx_.now_ns += dt;
    DispatchCycle(d_, ctx_);
  }
  void Event(DeviceEventKind k, NmtState nmt = NmtState::kOperational, std::uint16_t status = 0,
             std::uint16_t code = 0) {
    DeviceEvent e;
    e.kind = k;
    e.nmt = nmt;
    e.status = status;
    e.emcy_code = code;
    DispatchEvent(d_, e, ctx_);
  }
  // inputs of one cycle as the Bus feeds them: event, working counter, cycle
  void ValidInputs(std::uint16_t status) {
    Event(DeviceEventKind::kInputs, NmtState::kOperational, status);
    ++d_.consecutive_valid;
    d_.consecutive_missed = 0;
    Cycle();
  }
  void MissingInputs() {
    d_.consecutive_valid = 0;
    ++d_.consecutive_missed;
    Cycle();
  }
  bool Sent(NmtCommand cmd) {
    for (std::size_t i = 0; i < queue_.size; ++i)
      if (frames_[i].id == 0 && frames_[i].data[0] == static_cast<std::uint8_t>(cmd) &&
          frames_[i].data[1] == d_.node)
        return true;
    return false;
  }
  void BringToOp() {
    RequestState(d_, DeviceState::kOp);
    Cycle();
    Event(DeviceEventKind::kBootUp, NmtState::kBootUp);
    Cycle();
    ValidInputs(status_bit::kReady);
    ValidInputs(status_bit::kReady);
    ValidInputs(status_bit::kReady);
    ValidInputs(status_bit::kReady | status_bit::kEnabled);
    ASSERT_EQ(d_.state, DeviceState::kOp);
    queue_.size = 0;
  }

  StateMachineTiming timing_;
  std::array<CanFrame, 16> frames_{};
  FrameQueue queue_;
  StateMachineContext ctx_;
  DeviceRuntime d_;
};

TEST_F(StateMachine, TableHasOneRowPerStateWithEveryHandler) {
  const char* names[] = {"INIT", "PRE-OP", "SAFE-OP", "OP"};
  for (int s = 0; s < kNumDeviceStates; ++s) {
    const StateHandlers& h = kDeviceStateTable[s];
    EXPECT_STREQ(h.name, names[s]);
    EXPECT_NE(h.on_enter, nullptr);
    EXPECT_NE(h.on_frame, nullptr);
    EXPECT_NE(h.on_cycle, nullptr);
    EXPECT_NE(h.on_timeout, nullptr);
    EXPECT_NE(h.on_leave, nullptr);
  }
}

TEST_F(StateMachine, InitPreOpSafeOpOp) {
  RequestState(d_, DeviceState::kOp);
  Cycle();
  EXPECT_TRUE(Sent(NmtCommand::kResetCommunication));
  EXPECT_EQ(d_.state, DeviceState::kInit);
  Event(DeviceEventKind::kBootUp, NmtState::kBootUp);
  EXPECT_EQ(d_.state, DeviceState::kPreOp);
  Cycle();
  EXPECT_TRUE(Sent(NmtCommand::kStart));
  ValidInputs(status_bit::kReady);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_FALSE(d_.enable_requested) << "outputs stay safe until inputs were valid long enough";
  ValidInputs(status_bit::kReady);
  EXPECT_TRUE(d_.enable_requested);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp) << "OP only once the device confirms the enable";
  ValidInputs(status_bit::kReady | status_bit::kEnabled);
  EXPECT_EQ(d_.state, DeviceState::kOp);
  EXPECT_EQ(d_.error, DeviceError::kNone);
}

TEST_F(StateMachine, InitTimeoutRetriesTheReset) {
  RequestState(d_, DeviceState::kOp);
  Cycle();
  queue_.size = 0;
  for (int i = 0; i < 98; ++i) Cycle();  // t = 99 ms, the timer started at 0
  EXPECT_EQ(d_.counters.retries, 0u);
  Cycle(2 * kMs);
  EXPECT_EQ(d_.state, DeviceState::kInit);
  EXPECT_EQ(d_.error, DeviceError::kNoBootUp);
  EXPECT_EQ(d_.counters.retries, 1u);
  EXPECT_TRUE(Sent(NmtCommand::kResetCommunication));
}

TEST_F(StateMachine, PreOpTimeoutWithoutInputsGoesBackToInit) {
  RequestState(d_, DeviceState::kOp);
  Cycle();
  Event(DeviceEventKind::kBootUp, NmtState::kBootUp);
  for (int i = 0; i < 99; ++i) {
    Event(DeviceEventKind::kHeartbeat, NmtState::kPreOperational);  // alive, but no PDOs
    Cycle();
  }
  EXPECT_EQ(d_.state, DeviceState::kPreOp);
  Cycle(5 * kMs);
  EXPECT_EQ(d_.state, DeviceState::kInit);
  EXPECT_EQ(d_.error, DeviceError::kNoInputs);
}

TEST_F(StateMachine, EnableTimeoutLatchesAndAcknowledgeAllowsOp) {
  RequestState(d_, DeviceState::kOp);
  Cycle();
  Event(DeviceEventKind::kBootUp, NmtState::kBootUp);
  Cycle();
  for (int i = 0; i < 120; ++i) ValidInputs(status_bit::kReady);  // never confirms the enable
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_EQ(d_.error, DeviceError::kEnableRefused);
  EXPECT_TRUE(d_.error_latched);
  EXPECT_FALSE(d_.enable_requested);
  ValidInputs(status_bit::kReady | status_bit::kEnabled);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp) << "a latched error blocks OP";
  AcknowledgeFault(d_);
  EXPECT_TRUE(d_.fault_reset_pending);
  ValidInputs(status_bit::kReady);
  ValidInputs(status_bit::kReady);
  ValidInputs(status_bit::kReady | status_bit::kEnabled);
  EXPECT_EQ(d_.state, DeviceState::kOp);
}

TEST_F(StateMachine, OpFaultsGoDownAndLatch) {
  BringToOp();
  // one missing cycle is tolerated (flagged by the bus), more than max_held_cycles is not
  for (int i = 0; i < 3; ++i) MissingInputs();
  EXPECT_EQ(d_.state, DeviceState::kOp);
  MissingInputs();
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_EQ(d_.error, DeviceError::kInputsLost);
  EXPECT_TRUE(d_.error_latched);
  // a second fault while in SAFE-OP: inputs still missing -> PRE-OP
  for (int i = 0; i < 4; ++i) MissingInputs();
  EXPECT_EQ(d_.state, DeviceState::kPreOp);
}

TEST_F(StateMachine, EmcyStatusFaultAndDisableDropToSafeOp) {
  BringToOp();
  Event(DeviceEventKind::kEmcy, NmtState::kOperational, 0, emcy::kSensor);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_EQ(d_.error, DeviceError::kEmcy);
  EXPECT_EQ(d_.counters.last_emcy_code, emcy::kSensor);

  d_ = DeviceRuntime{};
  d_.node = 5;
  BringToOp();
  ValidInputs(status_bit::kReady | status_bit::kEnabled | status_bit::kFault);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_EQ(d_.error, DeviceError::kDeviceFault);

  d_ = DeviceRuntime{};
  d_.node = 5;
  BringToOp();
  ValidInputs(status_bit::kReady);
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_EQ(d_.error, DeviceError::kDeviceDisabled);
}

TEST_F(StateMachine, HeartbeatLostOrUnexpectedBootUpGoToInit) {
  BringToOp();
  const std::int64_t last_heartbeat = d_.last_heartbeat_ns;  // the boot-up
  while (ctx_.now_ns + kMs - last_heartbeat <= timing_.heartbeat_timeout_ns) {
    ValidInputs(status_bit::kReady | status_bit::kEnabled);
    ASSERT_EQ(d_.state, DeviceState::kOp);
  }
  ValidInputs(status_bit::kReady | status_bit::kEnabled);
  EXPECT_EQ(d_.state, DeviceState::kInit);
  EXPECT_EQ(d_.error, DeviceError::kHeartbeatLost);

  d_ = DeviceRuntime{};
  d_.node = 5;
  BringToOp();
  Event(DeviceEventKind::kBootUp, NmtState::kBootUp);
  EXPECT_EQ(d_.state, DeviceState::kInit);
  EXPECT_EQ(d_.error, DeviceError::kUnexpectedReset);

  d_ = DeviceRuntime{};
  d_.node = 5;
  BringToOp();
  Event(DeviceEventKind::kHeartbeat, NmtState::kPreOperational);
  EXPECT_EQ(d_.state, DeviceState::kPreOp);
  EXPECT_EQ(d_.error, DeviceError::kLeftOperational);
}

TEST_F(StateMachine, DownwardRequestsAreObeyedAtOnce) {
  BringToOp();
  RequestState(d_, DeviceState::kSafeOp);
  Cycle();
  EXPECT_EQ(d_.state, DeviceState::kSafeOp);
  EXPECT_FALSE(d_.error_latched);
  RequestState(d_, DeviceState::kInit);
  Cycle();
  EXPECT_EQ(d_.state, DeviceState::kInit);
}

}  // namespace
}  // namespace hyq::hal
