// The runtime's pieces on their own: the deadline monitor's count and fault, the safety state
// machine's decisions (torque per mode, device requests on entering FAULT / STOPPED, stop
// completion, auto-enable once, the acknowledgement handshake).
#include <gtest/gtest.h>

#include <cstring>

#include <sched.h>

#include "servo/runtime/deadline_monitor.h"
#include "servo/runtime/realtime_thread.h"
#include "servo/runtime/safety_state_machine.h"

namespace hyq::servo {
namespace {

TEST(DeadlineMonitor, FaultsOnlyAfterTheConfiguredMissesInARow) {
  DeadlineMonitor m({.budget_fraction = 0.5, .max_consecutive_misses = 3}, 1e-3);
  EXPECT_EQ(m.budget_ns(), 500'000);
  EXPECT_FALSE(m.Observe(600'000, 600'000));
  EXPECT_FALSE(m.Observe(600'000, 600'000));
  EXPECT_FALSE(m.Observe(400'000, 400'000));  // one fits: the run starts again
  EXPECT_FALSE(m.Observe(600'000, 600'000));
  EXPECT_FALSE(m.Observe(600'000, 600'000));
  const Fault f = m.Observe(700'000, 650'000);
  ASSERT_TRUE(f);
  EXPECT_EQ(f.reason, EventReason::kDeadlineMiss);
  EXPECT_NE(std::strstr(f.detail.data(), "3 consecutive deadline misses (last 650.0 us, budget 500.0 us)"),
            nullptr) << f.detail.data();
  EXPECT_EQ(m.misses(), 5u);
  EXPECT_EQ(m.max_consecutive(), 3u);
}

// lock-step without stop_in_lockstep: every miss counted, none a fault
TEST(DeadlineMonitor, CountsButNeverFaultsWhenNotEnforced) {
  DeadlineMonitor m({.budget_fraction = 0.5, .max_consecutive_misses = 2}, 1e-3, /*enforce=*/false);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(m.Observe(900'000, 900'000)) << i;
  EXPECT_EQ(m.misses(), 10u);
  EXPECT_EQ(m.max_consecutive(), 10u);
}

TEST(SafetyStateMachine, DecidesTorqueAndDeviceRequestsPerMode) {
  SafetyLimits limits;
  limits.damping_duration_s = 0.003;  // three cycles at 1 kHz
  SafetyStateMachine s(limits, 1e-3, /*auto_enable=*/true, /*stop_timeout_s=*/0.005);
  std::uint64_t cycle = 0;
  s.BeginCycle(cycle, 0);
  s.BringUpComplete();
  EXPECT_EQ(s.Decide(false).torque, SafetyDecision::Torque::kZero);
  // auto-enable waits for the estimate, then enables once
  s.BeginCycle(++cycle, 0);
  EXPECT_FALSE(s.MaybeAutoEnable(false));
  EXPECT_TRUE(s.MaybeAutoEnable(true));
  SafetyDecision d = s.Decide(false);
  EXPECT_EQ(d.mode, ServoMode::kActive);
  EXPECT_EQ(d.torque, SafetyDecision::Torque::kController);
  EXPECT_FALSE(d.request_devices);
  ASSERT_TRUE(s.Disable());
  EXPECT_FALSE(s.MaybeAutoEnable(true));  // once only
  // a fault in STANDBY: FAULT, zero torque, the devices asked to SAFE-OP once
  s.Report(MakeFault(EventReason::kBusOff, -1, 2, "bus rh is bus-off"));
  d = s.Decide(false);
  EXPECT_EQ(d.mode, ServoMode::kFault);
  EXPECT_EQ(d.torque, SafetyDecision::Torque::kZero);
  EXPECT_TRUE(d.request_devices);
  EXPECT_EQ(d.device_request, hal::DeviceState::kSafeOp);
  EXPECT_FALSE(s.Decide(false).request_devices);
  // acknowledge: a handshake, STANDBY only once the devices are in OP with clean inputs
  ASSERT_TRUE(s.RequestAcknowledge());
  EXPECT_FALSE(s.expects_devices_in_op());
  s.BeginCycle(++cycle, 0);
  s.Update({.inputs_ok = true, .devices_in_op = false});
  EXPECT_EQ(s.mode(), ServoMode::kFault);
  s.BeginCycle(++cycle, 0);
  s.Update({.inputs_ok = true, .devices_in_op = true});
  EXPECT_EQ(s.mode(), ServoMode::kStandby);
  EXPECT_FALSE(s.acknowledge_pending());
  // enable, then stop: DAMPING (damping torque) for damping_duration, then STOPPED (PRE-OP)
  ASSERT_TRUE(s.Enable(EventReason::kEnableCommand));
  s.Stop();
  EXPECT_EQ(s.Decide(false).torque, SafetyDecision::Torque::kDamping);
  for (int i = 0; i < 3; ++i) s.BeginCycle(++cycle, 0);
  d = s.Decide(false);
  EXPECT_EQ(d.mode, ServoMode::kStopped);
  EXPECT_TRUE(d.request_devices);
  EXPECT_EQ(d.device_request, hal::DeviceState::kPreOp);
  EXPECT_FALSE(d.finished);
  EXPECT_TRUE(s.Decide(true).finished);  // devices down
  // or the stop timeout passes
  for (int i = 0; i < 6; ++i) s.BeginCycle(++cycle, 0);
  EXPECT_TRUE(s.Decide(false).finished);
}

// the loop's sit-down holds DAMPING past its timer while the robot still moves; the hold is
// cleared by the next transition
TEST(SafetyStateMachine, HeldDampingOutlastsItsTimerUntilReleased) {
  SafetyLimits limits;
  limits.damping_duration_s = 0.002;
  SafetyStateMachine s(limits, 1e-3);
  s.BringUpComplete();
  ASSERT_TRUE(s.Enable(EventReason::kEnableCommand));
  s.Stop();
  ASSERT_EQ(s.mode(), ServoMode::kDamping);
  std::uint64_t cycle = 0;
  for (int i = 0; i < 50; ++i) {
    s.Decide(false, /*hold_damping=*/true);
    s.BeginCycle(++cycle, 0);
  }
  EXPECT_EQ(s.mode(), ServoMode::kDamping);  // 50 cycles, the timer says 2
  s.Decide(false, /*hold_damping=*/false);
  s.BeginCycle(++cycle, 0);
  EXPECT_EQ(s.mode(), ServoMode::kStopped);
}

TEST(SafetyStateMachine, AcknowledgeOutsideFaultIsRefusedWithAnEvent) {
  SafetyStateMachine s(SafetyLimits{}, 1e-3);
  s.BringUpComplete();
  SafetyEvent e;
  while (s.Take(&e)) {
  }
  EXPECT_FALSE(s.RequestAcknowledge());
  ASSERT_TRUE(s.Take(&e));
  EXPECT_EQ(e.reason, EventReason::kCommandRejected);
  EXPECT_STREQ(e.detail.data(), "acknowledge refused in standby (only in fault)");
}

}  // namespace
// realtime.cpu: auto (config/hyq_servo_sim.yaml) and hyq-sim --cpu auto: the servo thread and the
// plant's stepping thread on different cores where two exist, nothing pinned in lock-step
TEST(RealtimeThread, AutoCpuPinsOnlyOnTheRealTimeClockWithTwoCores) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  int first = -1, last = -1;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) {
      if (first < 0) first = c;
      last = c;
    }
  EXPECT_EQ(ResolveCpu(kAutoCpu, false, -1), kNoCpu) << "lock-step: not pinned";
  EXPECT_EQ(ResolveCpu(3, false, -1), 3) << "an explicit CPU is kept";
  EXPECT_EQ(ResolveCpu(kNoCpu, true, 0), kNoCpu);
  if (CPU_COUNT(&allowed) < 2) {
    EXPECT_EQ(ResolveCpu(kAutoCpu, true, -1), kNoCpu) << "one core: not pinned";
    return;
  }
  EXPECT_EQ(ResolveCpu(kAutoCpu, true, -1), last) << "the servo thread: the last allowed CPU";
  EXPECT_EQ(ResolveCpu(kAutoCpu, true, 0), first) << "the plant: the first allowed CPU";
  EXPECT_NE(ResolveCpu(kAutoCpu, true, -1), ResolveCpu(kAutoCpu, true, 0));
}

}  // namespace hyq::servo
