// Where tests find the project's files and the reference data in ../shared.
#pragma once

#include <filesystem>
#include <string>

namespace hyq::testing {

/// The source tree (HYQ_SOURCE_DIR, set by tests/CMakeLists.txt).
inline std::filesystem::path SourceDir() { return HYQ_SOURCE_DIR; }

/// The project's own HyQ URDF.
inline std::filesystem::path ProjectUrdf() { return SourceDir() / "config/robots/hyq.urdf"; }

/// ../shared beside the checkout, or empty when it is absent (tests that need it skip and say so).
inline std::filesystem::path SharedDir() {
  std::filesystem::path p = HYQ_SHARED_DIR;
  return std::filesystem::is_directory(p) ? p : std::filesystem::path{};
}

}  // namespace hyq::testing
