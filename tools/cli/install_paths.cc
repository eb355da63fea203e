#include "tools/cli/install_paths.h"

#include <unistd.h>

#include <array>
#include <cstdlib>

namespace hyq::cli {
namespace {

std::string Parent(std::string_view path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string_view::npos) return ".";
  if (slash == 0) return "/";
  return std::string(path.substr(0, slash));
}

}  // namespace

InstallPaths PathsForExecutable(std::string_view exe) {
  InstallPaths p;
  const std::string_view build_dir = HYQ_BUILD_DIR;
  if (exe.size() > build_dir.size() && exe.starts_with(build_dir) && exe[build_dir.size()] == '/') {
    p.config_dir = HYQ_SOURCE_CONFIG_DIR;
    p.data_dir = HYQ_BUILD_DIR;
    return p;
  }
  p.installed = true;
  const std::string prefix = Parent(Parent(exe));
  p.config_dir = prefix == "/usr" ? "/etc/hyq" : (prefix == "/" ? "" : prefix) + "/etc/hyq";
  p.data_dir = (prefix == "/" ? "" : prefix) + "/share/hyq";
  return p;
}

const InstallPaths& Paths() {
  static const InstallPaths paths = [] {
    std::array<char, 4096> exe{};
    const ssize_t n = ::readlink("/proc/self/exe", exe.data(), exe.size() - 1);
    return PathsForExecutable(n > 0 ? std::string_view(exe.data(), static_cast<std::size_t>(n))
                                    : std::string_view("/usr/bin/unknown"));
  }();
  return paths;
}

std::string DefaultServoConfig() { return Paths().config_dir + "/hyq_servo.yaml"; }
std::string DefaultSimServoConfig() { return Paths().config_dir + "/hyq_servo_sim.yaml"; }
std::string DefaultHalConfig() { return Paths().config_dir + "/hyq_hal.yaml"; }
std::string DefaultUrdf() { return Paths().config_dir + "/robots/hyq.urdf"; }

std::string DefaultViewerWebDir() {
  return Paths().installed ? Paths().data_dir + "/viewer" : std::string(HYQ_VIEWER_BUILD_WEB_DIR);
}

std::string DataFile(std::string_view build_tree_path, std::string_view name) {
  return Paths().installed ? Paths().data_dir + "/" + std::string(name) : std::string(build_tree_path);
}

std::string WithPaths(std::string help) {
  static constexpr std::string_view kToken = "@config@";
  // help2man sets HYQ_HELP_CONFIG_DIR when it makes the manual pages, which describe the package
  const char* for_manual = std::getenv("HYQ_HELP_CONFIG_DIR");
  const std::string dir = for_manual != nullptr ? std::string(for_manual) : Paths().config_dir;
  for (std::size_t at = help.find(kToken); at != std::string::npos; at = help.find(kToken, at)) {
    help.replace(at, kToken.size(), dir);
    at += dir.size();
  }
  return help;
}

}  // namespace hyq::cli
