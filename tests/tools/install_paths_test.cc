// Where the tools find the configuration (tools/cli/install_paths.h): the source tree's config/
// from the build tree; <prefix>/etc/hyq, or /etc/hyq for the prefix /usr, when installed.
#include "tools/cli/install_paths.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace hyq::cli {
namespace {

TEST(InstallPaths, TheBuildTreeUsesTheSourceTreesConfiguration) {
  const InstallPaths p = PathsForExecutable(HYQ_TEST_BUILD_DIR "/tools/hyq-servod/hyq-servod");
  EXPECT_FALSE(p.installed);
  EXPECT_EQ(p.config_dir, HYQ_TEST_SOURCE_DIR "/config");
}

TEST(InstallPaths, ThePrefixUsrKeepsTheConfigurationInEtc) {
  const InstallPaths p = PathsForExecutable("/usr/bin/hyq-servod");
  EXPECT_TRUE(p.installed);
  EXPECT_EQ(p.config_dir, "/etc/hyq");
  EXPECT_EQ(p.data_dir, "/usr/share/hyq");
}

TEST(InstallPaths, AnotherPrefixKeepsItUnderThePrefix) {
  const InstallPaths p = PathsForExecutable("/opt/robot/bin/hyq-sim");
  EXPECT_TRUE(p.installed);
  EXPECT_EQ(p.config_dir, "/opt/robot/etc/hyq");
  EXPECT_EQ(p.data_dir, "/opt/robot/share/hyq");
  // a directory beside the build tree whose name begins like it is not the build tree
  EXPECT_TRUE(PathsForExecutable(HYQ_TEST_BUILD_DIR "-other/bin/hyq-sim").installed);
}

TEST(InstallPaths, ThisTestRunsFromTheBuildTree) {
  EXPECT_FALSE(Paths().installed);
  EXPECT_EQ(DefaultServoConfig(), HYQ_TEST_SOURCE_DIR "/config/hyq_servo.yaml");
  EXPECT_EQ(DefaultUrdf(), HYQ_TEST_SOURCE_DIR "/config/robots/hyq.urdf");
}

TEST(InstallPaths, HelpTextsNameTheConfigurationDirectory) {
  ::unsetenv("HYQ_HELP_CONFIG_DIR");
  EXPECT_EQ(WithPaths("a @config@/x.yaml, b @config@"),
            "a " HYQ_TEST_SOURCE_DIR "/config/x.yaml, b " HYQ_TEST_SOURCE_DIR "/config");
  ::setenv("HYQ_HELP_CONFIG_DIR", "/etc/hyq", 1);  // the manual pages describe the package
  EXPECT_EQ(WithPaths("(default @config@/hyq_hal.yaml)"), "(default /etc/hyq/hyq_hal.yaml)");
  ::unsetenv("HYQ_HELP_CONFIG_DIR");
}

}  // namespace
}  // namespace hyq::cli
