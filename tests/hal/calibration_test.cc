#include "hal/calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "hal/config_error.h"
#include "hal/hal_config.h"

namespace hyq::hal {
namespace {

TEST(Calibration, LeverArmHandComputed) {
  // a = 5 cm, b = 30 cm, phi = 90 deg: L = sqrt(a^2 + b^2), r = a b / L
  const CylinderGeometry g{0.05, 0.30, std::numbers::pi / 2, 1.0};
  EXPECT_NEAR(CylinderLength(g, 0.0), std::sqrt(0.0925), 1e-12);
  EXPECT_NEAR(LeverArm(g, 0.0), 0.015 / std::sqrt(0.0925), 1e-12);
  // phi = 60 deg: L^2 = a^2 + b^2 - ab = 0.0775, r = ab sin60 / L
  EXPECT_NEAR(CylinderLength(g, -std::numbers::pi / 6), std::sqrt(0.0775), 1e-12);
  EXPECT_NEAR(LeverArm(g, -std::numbers::pi / 6), 0.015 * std::sqrt(3.0) / 2 / std::sqrt(0.0775),
              1e-12);
  const CylinderGeometry mirrored{0.05, 0.30, std::numbers::pi / 2, -1.0};
  EXPECT_NEAR(LeverArm(mirrored, 0.0), -LeverArm(g, 0.0), 1e-15);
}

TEST(Calibration, LeverArmIsTheDerivativeOfTheCylinderLength) {
  const HalConfig cfg = DefaultHalConfig();
  const double h = 1e-6;
  for (int j = 0; j < kNumJoints; ++j) {
    const JointCalibration& c = cfg.joints[static_cast<std::size_t>(j)];
    if (c.kind != ActuatorKind::kCylinder) continue;
    for (int i = 0; i <= 20; ++i) {
      const double q = c.q_min_rad + (c.q_max_rad - c.q_min_rad) * i / 20.0;
      const double fd =
          (CylinderLength(c.cylinder, q + h) - CylinderLength(c.cylinder, q - h)) / (2 * h);
      EXPECT_NEAR(LeverArm(c.cylinder, q), fd, 1e-8) << JointName(j) << " q=" << q;
    }
  }
}

TEST(Calibration, ForwardOfInverseIsIdentityForEveryJoint) {
  const HalConfig cfg = DefaultHalConfig();
  std::mt19937 rng(42);
  for (int j = 0; j < kNumJoints; ++j) {
    const JointCalibration& c = cfg.joints[static_cast<std::size_t>(j)];
    std::uniform_real_distribution<double> qd(c.q_min_rad, c.q_max_rad), vd(-12.0, 12.0),
        td(-150.0, 150.0);
    const double count_rad = 2 * std::numbers::pi / c.encoder.counts_per_rev;
    for (int i = 0; i < 200; ++i) {
      const double q = qd(rng), v = vd(rng), tau = td(rng);
      // rad -> counts -> rad: within half a count
      EXPECT_NEAR(EncoderCountsToRad(c, RadToEncoderCounts(c, q)), q, 0.5 * count_rad + 1e-12);
      EXPECT_NEAR(EncoderRateToRadPerSec(c, RadPerSecToEncoderRate(c, v)), v, 0.5 * count_rad + 1e-12);
      // counts -> rad -> counts: exact
      const std::int32_t counts = RadToEncoderCounts(c, q);
      EXPECT_EQ(RadToEncoderCounts(c, EncoderCountsToRad(c, counts)), counts);
      // torque -> sensor counts -> torque: within half a count through the lever arm
      const double r = c.kind == ActuatorKind::kCylinder ? std::abs(LeverArm(c.cylinder, q)) : 1.0;
      EXPECT_NEAR(EffortCountsToTorque(c, TorqueToEffortCounts(c, tau, q), q), tau,
                  0.5 * std::abs(c.effort.gain) * r + 1e-12)
          << JointName(j);
      const std::int32_t effort = TorqueToEffortCounts(c, tau, q);
      EXPECT_EQ(TorqueToEffortCounts(c, EffortCountsToTorque(c, effort, q), q), effort);
    }
  }
}

TEST(Calibration, DirectionOffsetAndCylinderTorque) {
  JointCalibration c;
  c.encoder = {4096.0, 1000, -1};
  EXPECT_NEAR(EncoderCountsToRad(c, 1000 + 1024), -std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(EncoderRateToRadPerSec(c, 4096), -2 * std::numbers::pi, 1e-12);
  c.kind = ActuatorKind::kCylinder;
  c.effort = {0.5, 100};
  c.cylinder = {0.05, 0.30, std::numbers::pi / 2, 1.0};
  // 2100 counts -> 1000 N; at q = 0, r = ab/L
  EXPECT_NEAR(EffortCountsToSensorValue(c, 2100), 1000.0, 1e-12);
  EXPECT_NEAR(EffortCountsToTorque(c, 2100, 0.0), 1000.0 * 0.015 / std::sqrt(0.0925), 1e-9);
}

TEST(Calibration, DefaultsValidateAndBadGeometryIsRefusedByName) {
  const HalConfig cfg = DefaultHalConfig();
  for (int j = 0; j < kNumJoints; ++j)
    EXPECT_NO_THROW(ValidateCalibration(cfg.joints[static_cast<std::size_t>(j)], JointName(j)));
  JointCalibration bad = cfg.joints[1];
  bad.cylinder.phi0_rad = 0.0;  // the triangle folds flat inside the joint range
  try {
    ValidateCalibration(bad, "lf_hfe_joint");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("lf_hfe_joint"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("lever arm"), std::string::npos) << e.what();
  }
  bad = cfg.joints[0];
  bad.encoder.direction = 0;
  EXPECT_THROW(ValidateCalibration(bad, "lf_haa_joint"), ConfigError);
}

}  // namespace
}  // namespace hyq::hal
