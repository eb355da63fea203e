// hyq-config-reference: the table of every configuration key (servo file and HAL file), written
// from the config structs' Serialize. Prints it, or with --update FILE replaces the part of FILE
// between the markers (docs/configuration.md; tests/servo/config_archive_test.cc checks it).
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "config/config_reference.h"
#include "tools/cli/command_line.h"

namespace {

constexpr const char* kTool = "hyq-config-reference";
constexpr const char* kHelp =
    "usage: hyq-config-reference [--update FILE]\n"
    "The table of every configuration key (servo file and HAL file) from the config structs.\n"
    "  --update FILE   replace the generated part of FILE (docs/configuration.md) instead of\n"
    "                  printing the table\n";

int Update(const std::string& path, const std::string& table) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  const auto begin = text.find(hyq::config::kReferenceBegin);
  const auto end = text.find(hyq::config::kReferenceEnd);
  if (!in || begin == std::string::npos || end == std::string::npos || end < begin)
    throw std::runtime_error(path + ": expected a file with the lines\n" +
                             hyq::config::kReferenceBegin + "\n" + hyq::config::kReferenceEnd);
  const auto from = begin + std::strlen(hyq::config::kReferenceBegin) + 1;
  text.replace(from, end - from, table);
  std::ofstream(path) << text;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::optional<std::string> update;
  hyq::cli::CommandLine cl(argc, argv, kTool, kHelp);
  while (cl.Next()) {
    if (cl.Flag("--update")) update = cl.Value();
    else if (cl.IsOption()) cl.Unknown();
    else cl.Bad("argument", "no positional argument", cl.arg());
  }
  return hyq::cli::Run(kTool, [&] {
    const std::string table = hyq::config::ConfigReference();
    if (update) return Update(*update, table);
    std::fputs(table.c_str(), stdout);
    return 0;
  });
}
