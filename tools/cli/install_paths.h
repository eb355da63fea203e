// Where a tool finds the configuration and the files shipped with it. One rule, so that a tool
// run from the build tree, `cmake --install --prefix P` and the Debian package agree:
//   - run from the build tree: the source tree's config/ and the build tree's files;
//   - installed (any other place): the prefix is the directory above the executable's; the
//     configuration is in <prefix>/etc/hyq, or in /etc/hyq for the prefix /usr (GNUInstallDirs'
//     rule, which cmake/HyqInstall.cmake applies when it installs), the shared files in
//     <prefix>/share/hyq.
#pragma once

#include <string>
#include <string_view>

namespace hyq::cli {

struct InstallPaths {
  bool installed = false;
  std::string config_dir;  ///< hyq_servo.yaml, hyq_servo_sim.yaml, hyq_hal.yaml, robots/
  std::string data_dir;    ///< share/hyq: the viewer's page, the LCM types, the plotting script
};

/// The paths for this process (from /proc/self/exe, once).
const InstallPaths& Paths();
/// The paths for an executable at `exe` (what Paths() uses; exposed for tests).
InstallPaths PathsForExecutable(std::string_view exe);

/// The robot's servo configuration: <config>/hyq_servo.yaml.
std::string DefaultServoConfig();
/// The servo configuration for the simulated robot: <config>/hyq_servo_sim.yaml.
std::string DefaultSimServoConfig();
/// The HAL configuration: <config>/hyq_hal.yaml.
std::string DefaultHalConfig();
/// The robot model: <config>/robots/hyq.urdf.
std::string DefaultUrdf();
/// hyq-viewer's bundled page: the build tree's, or <data>/viewer.
std::string DefaultViewerWebDir();

/// A file shipped in share/hyq: `build_tree_path` run from the build tree, <data>/`name` installed.
std::string DataFile(std::string_view build_tree_path, std::string_view name);

/// `help` with every "@config@" replaced by Paths().config_dir, for --help texts (by
/// $HYQ_HELP_CONFIG_DIR when set: the manual pages name the Debian package's /etc/hyq).
std::string WithPaths(std::string help);

}  // namespace hyq::cli
