// Each configuration key is written once, in its struct's Serialize: a key added there is read
// from YAML with its bound, known to the unknown-key check and listed in the docs table, with no
// other change; docs/configuration.md's table is the one the structs give; the simulator's file
// ships the robot's controller.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

#include "config/config_reference.h"
#include "config/hal_config_loader.h"
#include "config/servo_config_loader.h"
#include "config/yaml_archive.h"
#include "hal/config_error.h"
#include "servo/runtime/deadline_monitor.h"
#include "tests/support/paths.h"

namespace hyq {
namespace {

// DeadlineConfig with one more key, added the only way a key is added: one line in Serialize.
struct DeadlineConfigWithGrace : servo::DeadlineConfig {
  double grace_s = 0.25;

  template <class A>
  void Serialize(A* a) {
    servo::DeadlineConfig::Serialize(a);
    a->Visit(hal::Key("grace_s", &grace_s).In(0.0, 1.0).Unit("s").Doc("a test-only key"));
  }
};

std::string Error(const std::string& yaml) {
  try {
    (void)config::ParseConfigYaml<DeadlineConfigWithGrace>(yaml, "probe.yaml");
  } catch (const hal::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ConfigArchive, AKeyAddedInSerializeIsReadBoundedCheckedAndDocumented) {
  // it loads, beside the struct's own keys; absent, it keeps its initialiser
  const auto c = config::ParseConfigYaml<DeadlineConfigWithGrace>(
      "budget_fraction: 0.8\ngrace_s: 0.5\n", "probe.yaml");
  EXPECT_DOUBLE_EQ(c.grace_s, 0.5);
  EXPECT_DOUBLE_EQ(c.budget_fraction, 0.8);
  EXPECT_DOUBLE_EQ(config::ParseConfigYaml<DeadlineConfigWithGrace>("{}", "probe.yaml").grace_s, 0.25);

  // its bound is enforced, with the file, the line, the key, the bound and the value
  EXPECT_EQ(Error("budget_fraction: 0.8\ngrace_s: 2\n"),
            "probe.yaml:2: key 'grace_s': expected a number in [0, 1], found '2'");

  // the unknown-key check knows it: the plain struct refuses it, the extended one lists it
  try {
    (void)config::ParseConfigYaml<servo::DeadlineConfig>("grace_s: 0.5\n", "plain.yaml");
    ADD_FAILURE() << "no error";
  } catch (const hal::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'grace_s'"), std::string::npos) << e.what();
  }
  const std::string typo = Error("grace_ss: 0.5\n");
  EXPECT_NE(typo.find("key 'grace_ss': expected one of the keys budget_fraction, "
                      "max_consecutive_misses, stop_in_lockstep, grace_s"),
            std::string::npos) << typo;

  // and the docs table lists it with its type, bound, default, unit and description
  const std::string table = config::KeyTable<DeadlineConfigWithGrace>();
  EXPECT_NE(table.find("| `grace_s` | number in [0, 1] | 0.25 | s | a test-only key |"),
            std::string::npos) << table;
  EXPECT_EQ(config::KeyTable<servo::DeadlineConfig>().find("grace_s"), std::string::npos);
}

// the loop period is stored once, in the HAL's timing: the servo file's rate replaces the HAL
// file's period, and without a rate the HAL file's period is the loop's
TEST(ConfigArchive, ThePeriodIsStoredOnce) {
  const auto dir = testing::SourceDir() / "config";
  const std::string robot = "robot:\n  urdf: robots/hyq.urdf\n  hal: hyq_hal.yaml\n"
                            "controller:\n  gains:\n    kp_tau: 100\n";
  const servo::ServoConfig at500 =
      config::ParseServoConfig(robot + "loop:\n  rate_hz: 500\n", "test.yaml", dir);
  EXPECT_DOUBLE_EQ(at500.hal.timing.cycle_period_s, 0.002);
  EXPECT_DOUBLE_EQ(at500.period_s(), 0.002);
  EXPECT_DOUBLE_EQ(at500.rate_hz(), 500.0);
  const servo::ServoConfig from_hal = config::ParseServoConfig(robot, "test.yaml", dir);
  EXPECT_DOUBLE_EQ(from_hal.period_s(), config::LoadHalConfig(dir / "hyq_hal.yaml").timing.cycle_period_s);
  EXPECT_EQ(config::LoadServoConfig(dir / "hyq_servo.yaml").rate_hz(), 1000.0);
}

TEST(ConfigArchive, DocsTableIsTheGeneratedOne) {
  const auto path = testing::SourceDir() / "docs/configuration.md";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::ostringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  const auto begin = text.find(config::kReferenceBegin);
  const auto end = text.find(config::kReferenceEnd);
  ASSERT_NE(begin, std::string::npos) << "no begin marker in " << path;
  ASSERT_NE(end, std::string::npos) << "no end marker in " << path;
  const auto from = begin + std::string(config::kReferenceBegin).size() + 1;
  EXPECT_EQ(text.substr(from, end - from), config::ConfigReference())
      << "docs/configuration.md's table is not the structs' one: run\n"
         "  build/ci/tools/hyq-config-reference/hyq-config-reference --update docs/configuration.md";
}

// What is tested is what runs on the robot: the simulator's configuration ships the robot's
// controller, gains, gait, estimator, safety and timing settings, and differs only in what is the
// simulator's (its buses and clock, the ground it simulates, enabling itself, the motion its
// demonstration runs where the robot's file starts standing, where the loop runs and how often
// the telemetry is sampled for the logger).
TEST(ConfigArchive, TheSimulatorShipsTheRobotsController) {
  const auto dir = testing::SourceDir() / "config";
  const auto robot = config::KeyValues(config::LoadServoConfig(dir / "hyq_servo.yaml"));
  const auto sim = config::KeyValues(config::LoadServoConfig(dir / "hyq_servo_sim.yaml"));
  const std::vector<std::string> simulator_only = {
      "loop.clock", "buses", "contact.mu", "operation.auto_enable", "reference.kind", "realtime.",
      "telemetry."};
  ASSERT_EQ(robot.size(), sim.size());
  int differ = 0;
  for (std::size_t i = 0; i < robot.size(); ++i) {
    ASSERT_EQ(robot[i].first, sim[i].first);
    const std::string& key = robot[i].first;
    const bool allowed = std::any_of(simulator_only.begin(), simulator_only.end(),
                                     [&](const std::string& p) { return key.rfind(p, 0) == 0; });
    if (allowed || robot[i].second == sim[i].second) continue;
    ++differ;
    ADD_FAILURE() << key << ": config/hyq_servo.yaml has '" << robot[i].second
                  << "', config/hyq_servo_sim.yaml '" << sim[i].second << "'";
  }
  EXPECT_EQ(differ, 0) << "the simulator's file may differ from the robot's only in "
                          "loop.clock, buses, contact.mu, operation.auto_enable, reference.kind, "
                          "realtime.* and telemetry.*";
}

}  // namespace
}  // namespace hyq
