// The graded stops' table and rules (servo/runtime/stop_class.h), row by row: what each fault
// reason loses, and the class of what is lost together; and the safety state machine's answer to
// each class in ACTIVE (a cut damps at once, a controlled or degraded stop sits down first).
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <vector>

#include "hal/loopback_bus.h"

#include "servo/runtime/safety_state_machine.h"
#include "servo/runtime/stop_class.h"

namespace hyq::servo {
namespace {

constexpr int kLfKfe = 2, kLfHaa = 0, kRfHfe = 4, kRhKfe = 11;

// every reason once, in EventReason order: a fault's scope, or none for what is not a fault
TEST(StopClassTable, OneRowPerReasonInOrderWithTheScopeOfWhatItLoses) {
  const std::set<EventReason> faults = {
      EventReason::kDeviceFault,    EventReason::kInputMissing,      EventReason::kBusOff,
      EventReason::kCorruptFrames,  EventReason::kNonFiniteInput,    EventReason::kOutOfRange,
      EventReason::kInputJump,      EventReason::kControllerFailure, EventReason::kDeadlineMiss,
      EventReason::kEstimatorFailure, EventReason::kForeignMaster};
  for (std::size_t i = 0; i < kNumEventReasons; ++i) {
    const auto r = static_cast<EventReason>(i);
    SCOPED_TRACE(ToString(r));
    EXPECT_EQ(kStopClassTable[i].reason, r);
    EXPECT_EQ(IsFaultReason(r), faults.count(r) == 1);
    if (!IsFaultReason(r)) {
      EXPECT_EQ(kStopClassTable[i].scope, FaultScope::kNothing);
    }
  }
  const auto scope = [](EventReason r) { return kStopClassTable[static_cast<std::size_t>(r)].scope; };
  for (EventReason r : {EventReason::kDeviceFault, EventReason::kInputMissing, EventReason::kCorruptFrames,
                        EventReason::kNonFiniteInput, EventReason::kOutOfRange, EventReason::kInputJump})
    EXPECT_EQ(scope(r), FaultScope::kSource) << ToString(r);
  EXPECT_EQ(scope(EventReason::kBusOff), FaultScope::kBus);
  EXPECT_EQ(scope(EventReason::kDeadlineMiss), FaultScope::kNothing);
  EXPECT_EQ(scope(EventReason::kForeignMaster), FaultScope::kNothing);
  EXPECT_EQ(scope(EventReason::kEstimatorFailure), FaultScope::kControl);
  EXPECT_EQ(scope(EventReason::kControllerFailure), FaultScope::kControl);
}

TEST(StopClassOf, OneDeviceIsDegradedMoreThanOneDevicesWorthIsCut) {
  LostInputs lost;
  EXPECT_EQ(StopClassOf(lost), StopClass::kControlled);
  lost.joint[kLfKfe] = true;
  EXPECT_EQ(StopClassOf(lost), StopClass::kDegraded);
  lost.joint[kLfHaa] = true;  // two joints of one leg: still that leg
  EXPECT_EQ(StopClassOf(lost), StopClass::kDegraded);
  lost.joint[1] = true;       // the whole leg, as its bus
  EXPECT_EQ(StopClassOf(lost), StopClass::kCut);
  lost.Clear();
  lost.joint[kLfKfe] = lost.joint[kRhKfe] = true;  // two legs
  EXPECT_EQ(StopClassOf(lost), StopClass::kCut);
  lost.Clear();
  lost.imu = true;
  EXPECT_EQ(StopClassOf(lost), StopClass::kDegraded);
  lost.joint[kRfHfe] = true;  // the IMU and a joint
  EXPECT_EQ(StopClassOf(lost), StopClass::kCut);
  lost.Clear();
  lost.control = true;
  EXPECT_EQ(StopClassOf(lost), StopClass::kCut);
}

TEST(Classify, EachScopeLosesWhatItNamesAndTheSetAccumulates) {
  // the default buses: lf, rf, lh, rh, the IMU on lf
  const hal::HalConfig config = hal::DefaultHalConfig();
  std::vector<std::unique_ptr<hal::LoopbackBus>> buses;
  std::vector<hal::CanChannel*> channels;
  for (const auto& b : config.buses) {
    buses.push_back(std::make_unique<hal::LoopbackBus>(b.name, 1));
    channels.push_back(&buses.back()->endpoint(0));
  }
  hal::Hal hal(config, channels);
  LostInputs lost;
  EXPECT_EQ(Classify(MakeFault(EventReason::kDeadlineMiss, -1, -1, "late"), hal, &lost),
            StopClass::kControlled);
  EXPECT_FALSE(lost.any());
  EXPECT_EQ(Classify(MakeFault(EventReason::kInputMissing, kLfKfe, 0, "lf_kfe"), hal, &lost),
            StopClass::kDegraded);
  EXPECT_TRUE(lost.joint[kLfKfe]);
  Fault imu = MakeFault(EventReason::kNonFiniteInput, -1, -1, "IMU");
  imu.imu = true;
  EXPECT_EQ(Classify(imu, hal, &lost), StopClass::kCut) << "the IMU after a joint";
  lost.Clear();
  EXPECT_EQ(Classify(imu, hal, &lost), StopClass::kDegraded);
  lost.Clear();
  // a bus: every device on it (rh: its three joints)
  EXPECT_EQ(Classify(MakeFault(EventReason::kBusOff, -1, 3, "rh"), hal, &lost), StopClass::kCut);
  for (int j = 9; j < 12; ++j) EXPECT_TRUE(lost.joint[static_cast<std::size_t>(j)]) << j;
  EXPECT_FALSE(lost.imu);
  lost.Clear();
  EXPECT_EQ(Classify(MakeFault(EventReason::kBusOff, -1, 0, "lf"), hal, &lost), StopClass::kCut);
  EXPECT_TRUE(lost.imu) << "the IMU is on lf's bus";
  lost.Clear();
  EXPECT_EQ(Classify(MakeFault(EventReason::kEstimatorFailure, -1, -1, "tilt"), hal, &lost),
            StopClass::kCut);
  EXPECT_TRUE(lost.control);
}

// A degraded stop in ACTIVE: ACTIVE while the caller sits down (the event says the class), no
// disable meanwhile, then DAMPING (not cut: the sit-down's) and FAULT; a cut during it damps at once
TEST(SafetyStateMachine, ADegradedFaultSitsDownInActiveThenDampsIntoFault) {
  SafetyLimits limits;
  limits.damping_duration_s = 0.002;
  SafetyStateMachine s(limits, 1e-3);
  s.SetFaultSitDown(true);
  s.BringUpComplete();
  ASSERT_TRUE(s.Enable(EventReason::kEnableCommand));
  SafetyEvent e;
  while (s.Take(&e)) {
  }
  s.Report(MakeFault(EventReason::kInputMissing, kLfKfe, 0, "lf_kfe"), StopClass::kDegraded);
  EXPECT_EQ(s.mode(), ServoMode::kActive);
  EXPECT_EQ(s.fault_stop(), StopClass::kDegraded);
  EXPECT_EQ(s.Decide(false).torque, SafetyDecision::Torque::kController);
  ASSERT_TRUE(s.Take(&e));
  EXPECT_EQ(e.from, ServoMode::kActive);
  EXPECT_EQ(e.to, ServoMode::kActive);
  EXPECT_EQ(e.reason, EventReason::kInputMissing);
  EXPECT_EQ(e.stop, StopClass::kDegraded);
  EXPECT_EQ(e.joint, kLfKfe);
  // the same reason again: latched, no new event
  s.Report(MakeFault(EventReason::kInputMissing, kLfKfe, 0, "lf_kfe"), StopClass::kDegraded);
  EXPECT_FALSE(s.Take(&e));
  // a disable would drop the robot: refused
  EXPECT_FALSE(s.Disable());
  EXPECT_EQ(s.mode(), ServoMode::kActive);
  ASSERT_TRUE(s.Take(&e));
  EXPECT_EQ(e.reason, EventReason::kCommandRejected);
  s.EndFaultSitDown(false);
  EXPECT_EQ(s.mode(), ServoMode::kDamping);
  EXPECT_FALSE(s.damping_cut()) << "the sit-down's damping";
  EXPECT_TRUE(s.damping_for_fault());
  ASSERT_TRUE(s.Take(&e));
  EXPECT_EQ(e.to, ServoMode::kDamping);
  EXPECT_EQ(e.stop, StopClass::kDegraded);
  std::uint64_t cycle = 0;
  for (int i = 0; i < 3; ++i) {
    s.Decide(false);
    s.BeginCycle(++cycle, 0);
  }
  EXPECT_EQ(s.mode(), ServoMode::kFault);
}

TEST(SafetyStateMachine, ACutOrAControlledStopWithoutASitDownDampsAtOnce) {
  for (const bool sit : {true, false}) {
    SCOPED_TRACE(sit ? "with a sit-down" : "without");
    SafetyStateMachine s(SafetyLimits{}, 1e-3);
    s.SetFaultSitDown(sit);
    s.BringUpComplete();
    ASSERT_TRUE(s.Enable(EventReason::kEnableCommand));
    s.Report(MakeFault(EventReason::kDeadlineMiss, -1, -1, "late"), StopClass::kControlled);
    EXPECT_EQ(s.mode(), sit ? ServoMode::kActive : ServoMode::kDamping);
    // a cut now (or any fault without a sit-down): damping at once, the damping a cut's
    s.Report(MakeFault(EventReason::kBusOff, -1, 3, "rh"), StopClass::kCut);
    EXPECT_EQ(s.mode(), ServoMode::kDamping);
    EXPECT_TRUE(s.damping_cut() || !sit);
    EXPECT_TRUE(s.damping_for_fault());
    EXPECT_EQ(s.fault_stop(), StopClass::kNone);
  }
}

// a stop asked for during a fault's sit-down: it ends in STOPPED, not FAULT
TEST(SafetyStateMachine, AStopDuringAFaultSitDownEndsStopped) {
  SafetyLimits limits;
  limits.damping_duration_s = 0.001;
  SafetyStateMachine s(limits, 1e-3);
  s.SetFaultSitDown(true);
  s.BringUpComplete();
  ASSERT_TRUE(s.Enable(EventReason::kEnableCommand));
  s.Report(MakeFault(EventReason::kForeignMaster, -1, 0, "a second master"), StopClass::kControlled);
  s.EndFaultSitDown(/*stop=*/true);
  ASSERT_EQ(s.mode(), ServoMode::kDamping);
  EXPECT_FALSE(s.damping_for_fault());
  std::uint64_t cycle = 0;
  for (int i = 0; i < 3; ++i) {
    s.Decide(false);
    s.BeginCycle(++cycle, 0);
  }
  EXPECT_EQ(s.mode(), ServoMode::kStopped);
}

}  // namespace
}  // namespace hyq::servo
