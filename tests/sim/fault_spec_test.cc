// hyq-sim's fault specs for a board's reset and a stall of the master: what they parse to, and
// each malformed one refused naming what was expected and what was found.
#include "sim/fault_spec.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "config/hal_config_loader.h"

namespace hyq::sim {
namespace {

hal::HalConfig Config() { return config::LoadHalConfig(HYQ_HAL_CONFIG); }

// the error's text, or "no error"
std::string Error(const std::string& spec) {
  try {
    (void)ParseFaultSpec(spec, Config());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(FaultSpec, ResetTargetsABoardOrTheImuWithABootTime) {
  const hal::HalConfig cfg = Config();
  const FaultSpec r = ParseFaultSpec("5.0:reset:lf_kfe", cfg);
  EXPECT_EQ(r.kind, FaultSpec::Kind::kReset);
  EXPECT_EQ(r.joint, 2);
  EXPECT_DOUBLE_EQ(r.t_s, 5.0);
  EXPECT_DOUBLE_EQ(r.duration_s, kDefaultBootTimeS);
  EXPECT_STREQ(ToString(r.kind), "reset");
  EXPECT_DOUBLE_EQ(ParseFaultSpec("1:reset:rh_hfe_joint:0.2", cfg).duration_s, 0.2);
  EXPECT_DOUBLE_EQ(ParseFaultSpec("1:reset:lf_kfe:0", cfg).duration_s, 0.0);  // boots at once
  const FaultSpec imu = ParseFaultSpec("1:reset:imu", cfg);
  EXPECT_EQ(imu.joint, FaultSpec::kImuTarget);
  EXPECT_DOUBLE_EQ(imu.duration_s, kDefaultBootTimeS);
}

TEST(FaultSpec, StallTargetsTheDaemonWithItsDuration) {
  const FaultSpec s = ParseFaultSpec("5.0:stall:daemon:0.019", Config());
  EXPECT_EQ(s.kind, FaultSpec::Kind::kStall);
  EXPECT_EQ(s.joint, -1);
  EXPECT_EQ(s.bus, -1);
  EXPECT_DOUBLE_EQ(s.duration_s, 0.019);
  EXPECT_STREQ(ToString(s.kind), "stall");
  EXPECT_DOUBLE_EQ(ParseFaultSpec("0:stall:daemon:0.001", Config()).duration_s, 0.001);
}

TEST(FaultSpec, ResetAndStallErrorsNameWhatWasExpectedAndFound) {
  EXPECT_EQ(Error("5:reboot:lf_kfe"),
            "fault '5:reboot:lf_kfe': expected a kind silent|corrupt|drop|nan|bus-off|emcy|reset|"
            "stall, found 'reboot'");
  EXPECT_EQ(Error("5:reset:lf_xyz"),
            "fault '5:reset:lf_xyz': expected a device (lf_haa, ..., imu) or joint (lf_haa_joint, "
            "...), found 'lf_xyz'");
  EXPECT_EQ(Error("5:reset:rh"),
            "fault '5:reset:rh': expected a device (lf_haa, ..., imu) or joint (lf_haa_joint, "
            "...), found 'rh'");
  EXPECT_EQ(Error("5:reset:daemon"),
            "fault '5:reset:daemon': expected a device (lf_haa, ..., imu) or joint (lf_haa_joint, "
            "...), found 'daemon'");
  for (const char* bad : {"-1", "x", "", "nan", "inf"})
    EXPECT_EQ(Error(std::string("5:reset:lf_kfe:") + bad),
              std::string("fault '5:reset:lf_kfe:") + bad +
                  "': expected a boot time in seconds >= 0, found '" + bad + "'");
  EXPECT_EQ(Error("5:stall:lf_kfe:0.019"),
            "fault '5:stall:lf_kfe:0.019': expected the target daemon for stall, found 'lf_kfe'");
  EXPECT_EQ(Error("5:stall:daemon"),
            "fault '5:stall:daemon': expected a stall in seconds (T:stall:daemon:S), found no "
            "duration");
  for (const char* bad : {"0", "-0.019", "0.0005", "61", "x", "", "nan", "inf"})
    EXPECT_EQ(Error(std::string("5:stall:daemon:") + bad),
              std::string("fault '5:stall:daemon:") + bad +
                  "': expected a stall in seconds from the cycle period (0.001) to 60, found '" +
                  bad + "'");
  EXPECT_EQ(Error("x:stall:daemon:0.019"),
            "fault 'x:stall:daemon:0.019': expected a time in simulated seconds >= 0, found 'x'");
}

}  // namespace
}  // namespace hyq::sim
