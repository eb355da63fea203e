// The commands' mode rules (servo/command/command_rules.h) against a fake CommandTarget: which
// command is taken in which mode, what each changes and what each notes, with no loop at all.
#include "servo/command/command_rules.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace hyq::servo {
namespace {

class FakeTarget final : public CommandTarget {
 public:
  ServoMode mode_now = ServoMode::kStandby;
  const char* estimate = nullptr;
  bool is_trot = true;
  std::vector<std::string> notes, faults;
  std::array<double, kNumFeet> mu{};
  ControllerKind kind = ControllerKind::kPid;
  double kp = 1.0, kd = 1.0;

  ServoMode mode() const noexcept override { return mode_now; }
  bool Enable(EventReason) noexcept override {
    if (mode_now != ServoMode::kStandby) return false;
    mode_now = ServoMode::kActive;
    return true;
  }
  bool Disable() noexcept override { return true; }
  bool Damp() noexcept override { return mode_now != ServoMode::kFault; }
  bool RequestAcknowledge() noexcept override { return mode_now == ServoMode::kFault; }
  void Note(EventReason, const char* detail) noexcept override { notes.emplace_back(detail); }
  void ReportFault(EventReason, const char* detail) noexcept override {
    faults.emplace_back(detail);
  }
  const char* EstimateNotReady() const noexcept override { return estimate; }
  void SetMu(const std::array<double, kNumFeet>& m) noexcept override { mu = m; }
  void SetControllerKind(ControllerKind k) noexcept override { kind = k; }
  void ScaleGains(double kp_scale, double kd_scale) noexcept override {
    kp = kp_scale;
    kd = kd_scale;
  }
  bool SetVelocity(const std::array<double, 3>& v, std::array<double, 3>* applied) noexcept override {
    if (!is_trot) return false;
    *applied = v;
    return true;
  }
};

ServoCommand Command(ServoCommand::Kind kind) {
  ServoCommand c;
  c.kind = kind;
  return c;
}

TEST(CommandRules, EnableNeedsAReadyEstimate) {
  FakeTarget t;
  t.estimate = "no_imu";
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kEnable), true, &t), CommandOutcome::kRejected);
  ASSERT_EQ(t.notes.size(), 1u);
  EXPECT_EQ(t.notes[0], "enable refused: the state estimate is not ready (no_imu)");
  t.estimate = nullptr;
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kEnable), true, &t), CommandOutcome::kEnabled);
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kEnable), true, &t), CommandOutcome::kApplied);
}

TEST(CommandRules, ControllerChangesOnlyOutsideActive) {
  FakeTarget t;
  ServoCommand c = Command(ServoCommand::Kind::kSetController);
  c.controller = ControllerKind::kTwoStageId;
  t.mode_now = ServoMode::kActive;
  EXPECT_EQ(ApplyCommand(c, true, &t), CommandOutcome::kRejected);
  EXPECT_EQ(t.kind, ControllerKind::kPid);
  t.mode_now = ServoMode::kStandby;
  EXPECT_EQ(ApplyCommand(c, true, &t), CommandOutcome::kApplied);
  EXPECT_EQ(t.kind, ControllerKind::kTwoStageId);
}

TEST(CommandRules, MuGainsAndVelocityAreTakenInAnyMode) {
  FakeTarget t;
  t.mode_now = ServoMode::kActive;
  ServoCommand mu = Command(ServoCommand::Kind::kSetMu);
  mu.mu = {0.1, 0.2, 0.3, 0.4};
  EXPECT_EQ(ApplyCommand(mu, true, &t), CommandOutcome::kApplied);
  EXPECT_EQ(t.mu, mu.mu);
  ServoCommand g = Command(ServoCommand::Kind::kSetGains);
  g.kp_scale = 0.5;
  g.kd_scale = 1.5;
  EXPECT_EQ(ApplyCommand(g, true, &t), CommandOutcome::kApplied);
  EXPECT_EQ(t.kp, 0.5);
  EXPECT_EQ(t.kd, 1.5);
  ServoCommand v = Command(ServoCommand::Kind::kSetVelocity);
  v.velocity = {0.2, 0.0, 0.1};
  EXPECT_EQ(ApplyCommand(v, true, &t), CommandOutcome::kApplied);
  EXPECT_EQ(t.notes.back(), "velocity = 0.200 m/s 0.000 m/s 0.100 rad/s");
  t.is_trot = false;
  EXPECT_EQ(ApplyCommand(v, true, &t), CommandOutcome::kRejected);
  EXPECT_EQ(t.notes.back(), "velocity refused: reference: expected trot, found another reference");
}

TEST(CommandRules, ABadCommandWhileActiveIsAFaultWhenConfigured) {
  FakeTarget t;
  ServoCommand bad = Command(ServoCommand::Kind::kRejected);
  bad.sequence = 7;
  EXPECT_EQ(ApplyCommand(bad, true, &t), CommandOutcome::kRejected);  // standby: no fault
  EXPECT_TRUE(t.faults.empty());
  t.mode_now = ServoMode::kActive;
  EXPECT_EQ(ApplyCommand(bad, false, &t), CommandOutcome::kRejected);
  EXPECT_TRUE(t.faults.empty());
  EXPECT_EQ(ApplyCommand(bad, true, &t), CommandOutcome::kRejected);
  ASSERT_EQ(t.faults.size(), 1u);
  EXPECT_EQ(t.faults[0], "a refused command (sequence 7) while active");
}

TEST(CommandRules, AcknowledgeOnlyInFault) {
  FakeTarget t;
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kAcknowledge), true, &t),
            CommandOutcome::kApplied);
  t.mode_now = ServoMode::kFault;
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kAcknowledge), true, &t),
            CommandOutcome::kAcknowledging);
  EXPECT_EQ(ApplyCommand(Command(ServoCommand::Kind::kDamp), true, &t), CommandOutcome::kApplied);
  EXPECT_EQ(t.notes.back(), "damp refused in fault");
}

}  // namespace
}  // namespace hyq::servo
