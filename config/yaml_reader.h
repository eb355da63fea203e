// The YAML reading helpers of config/: each lookup knows the file and the dotted key path, so
// that every error names the file, the line, the key, what was expected and what was found.
// config/yaml_archive.h reads the structs' keys with them.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "hal/config_error.h"

namespace hyq::config::detail {

using hal::ConfigError;

inline std::string Describe(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list of " + std::to_string(n.size());
  return "a map";
}

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void Fail(const YAML::Node& where, const std::string& key,
                         const std::string& expected, const std::string& found) const {
    // appended piecewise: GCC 12 warns falsely (-Wrestrict, bug 105329) on long operator+ chains
    std::string msg = source_;
    if (where.IsDefined()) msg.append(":").append(std::to_string(where.Mark().line + 1));
    msg.append(": key '").append(key).append("': expected ").append(expected);
    msg.append(", found ").append(found);
    throw ConfigError(msg);
  }

  double ToNumber(const YAML::Node& n, const std::string& key) const {
    double v = 0.0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      Fail(n, key, "a finite number", Describe(n));
    return v;
  }

  // Unknown keys and keys given twice are errors (yaml-cpp keeps the first of two silently).
  void Keys(const YAML::Node& map, const std::string& path,
            const std::vector<const char*>& allowed) const {
    std::vector<std::pair<std::string, int>> seen;
    for (const auto& kv : map) {
      const std::string k = kv.first.as<std::string>();
      for (const auto& [name, line] : seen)
        if (name == k)
          Fail(kv.first, Join(path, k), "each key once",
               "'" + k + "' a second time (first on line " + std::to_string(line) + ")");
      seen.emplace_back(k, kv.first.Mark().line + 1);
      bool ok = false;
      std::string list;
      for (const char* a : allowed) {
        ok = ok || k == a;
        list += std::string(list.empty() ? "" : ", ") + a;
      }
      if (!ok) Fail(kv.first, Join(path, k), "one of the keys " + list, "unknown key '" + k + "'");
    }
  }

  static std::string Join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

/// A number as a person would write it (no trailing zeros).
inline std::string FormatNumber(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

/// Parses YAML text; a syntax error names the source and the line.
inline YAML::Node ParseYaml(const Reader& r, const std::string& text) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(r.source() + ":" + std::to_string(e.mark.line + 1) +
                      ": not valid YAML: expected well-formed YAML, found " + e.msg);
  }
}

/// The whole file; `what` names it in the error ("the HAL configuration").
// A configuration is a small regular file: /dev/zero, a FIFO or a directory given by mistake
// must not hang the loader or exhaust memory.
inline constexpr std::uintmax_t kMaxConfigBytes = 1u << 20;

inline std::string ReadTextFile(const std::filesystem::path& path, const char* what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
    throw ConfigError(path.string() + ": cannot read " + what +
                      " (expected a regular YAML file, found a " +
                      (std::filesystem::is_directory(status) ? "directory" : "device, FIFO or socket") + ")");
  std::ifstream in(path);
  if (!in)
    throw ConfigError(path.string() + ": cannot open " + what + " (expected a readable YAML file)");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxConfigBytes)
    throw ConfigError(path.string() + ": " + what + " too large (expected at most " +
                      std::to_string(kMaxConfigBytes) + " bytes, found " + std::to_string(size) + ")");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace hyq::config::detail
