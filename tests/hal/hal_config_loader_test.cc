#include "config/hal_config_loader.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "hal/config_error.h"
#include "tests/support/paths.h"

namespace hyq::config {
namespace {

std::string DefaultYamlPath() { return (hyq::testing::SourceDir() / "config/hyq_hal.yaml").string(); }

std::string DefaultYaml() {
  std::ifstream in(DefaultYamlPath());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The error message of parsing the default file with `from` replaced by `to`.
std::string ErrorAfterEdit(const std::string& from, const std::string& to) {
  std::string text = DefaultYaml();
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  try {
    (void)ParseHalConfig(text, "edited.yaml");
  } catch (const hal::ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for " << to;
  return {};
}

TEST(HalConfigLoader, DefaultFileEqualsTheBuiltInDefaults) {
  const hal::HalConfig f = LoadHalConfig(DefaultYamlPath());
  const hal::HalConfig d = hal::DefaultHalConfig();
  EXPECT_EQ(f.timing.cycle_period_s, d.timing.cycle_period_s);
  EXPECT_EQ(f.timing.heartbeat_timeout_s, d.timing.heartbeat_timeout_s);
  EXPECT_EQ(f.timing.max_held_cycles, d.timing.max_held_cycles);
  EXPECT_EQ(f.max_bus_load, d.max_bus_load);
  ASSERT_EQ(f.buses.size(), d.buses.size());
  for (std::size_t b = 0; b < f.buses.size(); ++b) {
    EXPECT_EQ(f.buses[b].name, d.buses[b].name);
    EXPECT_EQ(f.buses[b].interface, d.buses[b].interface);
    EXPECT_EQ(f.buses[b].fd, d.buses[b].fd);
    EXPECT_EQ(f.buses[b].nominal_bitrate, d.buses[b].nominal_bitrate);
    EXPECT_EQ(f.buses[b].data_bitrate, d.buses[b].data_bitrate);
    ASSERT_EQ(f.buses[b].devices.size(), d.buses[b].devices.size());
    for (std::size_t i = 0; i < f.buses[b].devices.size(); ++i) {
      EXPECT_EQ(f.buses[b].devices[i].name, d.buses[b].devices[i].name);
      EXPECT_EQ(f.buses[b].devices[i].kind, d.buses[b].devices[i].kind);
      EXPECT_EQ(f.buses[b].devices[i].node_id, d.buses[b].devices[i].node_id);
      EXPECT_EQ(f.buses[b].devices[i].joint, d.buses[b].devices[i].joint);
    }
  }
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const auto& a = f.joints[static_cast<std::size_t>(j)];
    const auto& b = d.joints[static_cast<std::size_t>(j)];
    const auto name = hal::JointName(j);
    EXPECT_EQ(a.kind, b.kind) << name;
    EXPECT_EQ(a.encoder.counts_per_rev, b.encoder.counts_per_rev) << name;
    EXPECT_EQ(a.encoder.offset_counts, b.encoder.offset_counts) << name;
    EXPECT_EQ(a.encoder.direction, b.encoder.direction) << name;
    EXPECT_NEAR(a.effort.gain, b.effort.gain, 1e-15) << name;
    EXPECT_EQ(a.effort.offset_counts, b.effort.offset_counts) << name;
    EXPECT_NEAR(a.q_min_rad, b.q_min_rad, 1e-12) << name;
    EXPECT_NEAR(a.q_max_rad, b.q_max_rad, 1e-12) << name;
    EXPECT_EQ(a.torque_limit_Nm, b.torque_limit_Nm) << name;
    if (a.kind == hal::ActuatorKind::kCylinder) {
      EXPECT_EQ(a.cylinder.a_m, b.cylinder.a_m) << name;
      EXPECT_EQ(a.cylinder.b_m, b.cylinder.b_m) << name;
      EXPECT_NEAR(a.cylinder.phi0_rad, b.cylinder.phi0_rad, 1e-12) << name;
      EXPECT_EQ(a.cylinder.phi_per_q, b.cylinder.phi_per_q) << name;
    }
  }
}

TEST(HalConfigLoader, MissingFileNamesIt) {
  try {
    (void)LoadHalConfig("/nonexistent/hal.yaml");
    FAIL();
  } catch (const hal::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/hal.yaml: cannot open"), std::string::npos);
  }
}

// The joints' numbers are the file's, converted as the hand-written reader converted them
// (degrees times pi / 180, integers cast): the key list must not change a bit of a calibration.
TEST(HalConfigLoader, JointCalibrationsAreTheFileNumbersBitForBit) {
  constexpr double kDeg = std::numbers::pi / 180.0;
  const hal::HalConfig f = LoadHalConfig(DefaultYamlPath());
  const YAML::Node joints = YAML::LoadFile(DefaultYamlPath())["joints"];
  int cylinders = 0;
  for (int j = 0; j < hal::kNumJoints; ++j) {
    const std::string name(hal::JointName(j));
    const YAML::Node n = joints[name];
    const hal::JointCalibration& c = f.joints[static_cast<std::size_t>(j)];
    const bool rotary = n["actuator"].as<std::string>() == "rotary";
    EXPECT_EQ(c.kind, rotary ? hal::ActuatorKind::kRotary : hal::ActuatorKind::kCylinder) << name;
    EXPECT_EQ(c.encoder.counts_per_rev, n["encoder"]["counts_per_rev"].as<double>()) << name;
    EXPECT_EQ(c.encoder.offset_counts, n["encoder"]["offset_counts"].as<std::int32_t>()) << name;
    EXPECT_EQ(c.encoder.direction, n["encoder"]["direction"].as<int>()) << name;
    const YAML::Node s = n[rotary ? "torque_sensor" : "load_cell"];
    EXPECT_EQ(c.effort.gain, s[rotary ? "gain_Nm_per_count" : "gain_N_per_count"].as<double>()) << name;
    EXPECT_EQ(c.effort.offset_counts, s["offset_counts"].as<std::int32_t>()) << name;
    EXPECT_EQ(c.q_min_rad, kDeg * n["range_deg"][0].as<double>()) << name;
    EXPECT_EQ(c.q_max_rad, kDeg * n["range_deg"][1].as<double>()) << name;
    EXPECT_EQ(c.torque_limit_Nm, n["torque_limit_Nm"].as<double>()) << name;
    const hal::CylinderGeometry none;
    const YAML::Node g = n["cylinder"];
    EXPECT_EQ(c.cylinder.a_m, rotary ? none.a_m : g["a_m"].as<double>()) << name;
    EXPECT_EQ(c.cylinder.b_m, rotary ? none.b_m : g["b_m"].as<double>()) << name;
    EXPECT_EQ(c.cylinder.phi0_rad, rotary ? none.phi0_rad : kDeg * g["phi0_deg"].as<double>()) << name;
    EXPECT_EQ(c.cylinder.phi_per_q,
              rotary ? none.phi_per_q : static_cast<double>(g["phi_per_q"].as<int>())) << name;
    cylinders += rotary ? 0 : 1;
  }
  EXPECT_EQ(cylinders, 8);
}

TEST(HalConfigLoader, BadValuesNameFileLineKeyExpectedAndFound) {
  std::string m = ErrorAfterEdit("node_id: 2, joint: lh_hfe_joint", "node_id: two, joint: lh_hfe_joint");
  EXPECT_NE(m.find("edited.yaml:"), std::string::npos) << m;
  EXPECT_NE(m.find("key 'buses[2].devices[1].node_id': expected an integer in [1, 127], found 'two'"),
            std::string::npos) << m;

  m = ErrorAfterEdit("{a_m: 0.050, b_m: 0.300, phi0_deg: 80", "{a_m: 0.050, b_m: x, phi0_deg: 80");
  EXPECT_NE(m.find("key 'joints.lf_hfe_joint.cylinder.b_m': expected a finite number, found 'x'"),
            std::string::npos) << m;

  m = ErrorAfterEdit("    actuator: rotary\n", "    actuator: linear\n");
  EXPECT_NE(m.find("key 'joints.lf_haa_joint.actuator': expected one of 'rotary' 'cylinder', found "
                   "'linear'"),
            std::string::npos) << m;

  m = ErrorAfterEdit("joint: rf_kfe_joint", "joint: rf_knee_joint");
  EXPECT_NE(m.find("key 'buses[1].devices[2].joint'"), std::string::npos) << m;
  EXPECT_NE(m.find("found 'rf_knee_joint'"), std::string::npos) << m;

  m = ErrorAfterEdit("    torque_sensor: {gain_Nm_per_count", "    torque_sensr: {gain_Nm_per_count");
  EXPECT_NE(m.find("unknown key 'torque_sensr'"), std::string::npos) << m;

  m = ErrorAfterEdit("  rh_kfe_joint:", "  rh_knee:");
  EXPECT_NE(m.find("key 'joints.rh_knee'"), std::string::npos) << m;

  m = ErrorAfterEdit("range_deg: [-70, 25]", "range_deg: [25, -70]");
  EXPECT_NE(m.find("range_deg': expected min < max, found '25', '-70'"), std::string::npos) << m;

  // renamed: the old key is refused with the new one's name, not silently ignored
  m = ErrorAfterEdit("  max_held_cycles: 5", "  max_missed_cycles: 5");
  EXPECT_NE(m.find("key 'timing.max_missed_cycles': expected timing.max_held_cycles"),
            std::string::npos) << m;

  // a joint's keys follow its actuator: a rotary joint has no cylinder, a cylinder no torque sensor
  m = ErrorAfterEdit("    torque_sensor: {gain_Nm_per_count", "    cylinder: {a_m: 0.05}\n    torque_sensor: {gain_Nm_per_count");
  EXPECT_NE(m.find("key 'joints.lf_haa_joint.cylinder': expected one of the keys"), std::string::npos) << m;
  EXPECT_NE(m.find("unknown key 'cylinder'"), std::string::npos) << m;
  m = ErrorAfterEdit("    load_cell: {gain_N_per_count", "    torque_sensor: {gain_N_per_count");
  EXPECT_NE(m.find("unknown key 'torque_sensor'"), std::string::npos) << m;
  m = ErrorAfterEdit("phi_per_q: 1}", "phi_per_q: 0.5}");
  EXPECT_NE(m.find("cylinder.phi_per_q': expected +1 or -1, found '0.5'"), std::string::npos) << m;

  m = ErrorAfterEdit("direction: -1", "direction: 0");
  EXPECT_NE(m.find("encoder.direction': expected +1 or -1"), std::string::npos) << m;
}

TEST(HalConfigLoader, MissingKeysAndSyntaxErrors) {
  std::string m = ErrorAfterEdit("    interface: can3\n", "");
  EXPECT_NE(m.find("key 'buses[3].interface': expected a string, found nothing (the key is missing)"),
            std::string::npos) << m;
  m = ErrorAfterEdit("      - {name: imu, kind: imu, node_id: 16}", "      - {name: imu, kind: imu, node_id: [16}");
  EXPECT_NE(m.find("edited.yaml:"), std::string::npos) << m;
  EXPECT_NE(m.find("not valid YAML"), std::string::npos) << m;
}

TEST(HalConfigLoader, SemanticErrorsFromValidationNameTheFile) {
  std::string m = ErrorAfterEdit("name: rf_hfe, kind: actuator, node_id: 2", "name: rf_hfe, kind: actuator, node_id: 1");
  EXPECT_NE(m.find("edited.yaml: bus 'rf': node_id 1 used twice"), std::string::npos) << m;
  m = ErrorAfterEdit("max_bus_load: 0.80", "max_bus_load: 0.60");
  EXPECT_NE(m.find("edited.yaml: bus 'lf': worst-case load 74.9 %"), std::string::npos) << m;
  m = ErrorAfterEdit("phi0_deg: 80", "phi0_deg: 0");
  EXPECT_NE(m.find("calibration of lf_hfe_joint"), std::string::npos) << m;
}

// configurations that must be refused at load, each naming the key and what it expected
TEST(HalConfigLoader, DuplicateBusesAndAMissingImuAreErrors) {
  std::string m = ErrorAfterEdit("  - name: rf\n", "  - name: lf\n");
  EXPECT_NE(m.find("buses[1]: expected a unique bus name, found 'lf' a second time (buses[0])"),
            std::string::npos) << m;
  m = ErrorAfterEdit("    interface: can3\n", "    interface: can0\n");
  EXPECT_NE(m.find("bus 'rh': expected its own interface, found 'can0', the interface of bus 'lf' too"),
            std::string::npos) << m;
  m = ErrorAfterEdit("      - {name: imu, kind: imu, node_id: 16}\n", "");
  EXPECT_NE(m.find("expected exactly one IMU"), std::string::npos) << m;
  EXPECT_NE(m.find("found 0"), std::string::npos) << m;
}

}  // namespace
}  // namespace hyq::config
