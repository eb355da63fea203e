// hyq-config-reference: the table of every configuration key (servo file and HAL file), written
// from the config structs' Serialize. Prints it, or with --update FILE replaces the part of FILE
// between the markers (docs/configuration.md; tests/servo/config_archive_test.cc checks it).
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "config/config_reference.h"

int main(int argc, char** argv) {
  const std::string table = hyq::config::ConfigReference();
  if (argc == 1) {
    std::fputs(table.c_str(), stdout);
    return 0;
  }
  if (argc != 3 || std::strcmp(argv[1], "--update") != 0) {
    std::fprintf(stderr, "usage: hyq-config-reference [--update FILE]\n");
    return 2;
  }
  std::ifstream in(argv[2]);
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  const auto begin = text.find(hyq::config::kReferenceBegin);
  const auto end = text.find(hyq::config::kReferenceEnd);
  if (!in || begin == std::string::npos || end == std::string::npos || end < begin) {
    std::fprintf(stderr, "%s: expected a file with the lines\n%s\n%s\n", argv[2],
                 hyq::config::kReferenceBegin, hyq::config::kReferenceEnd);
    return 1;
  }
  const auto from = begin + std::strlen(hyq::config::kReferenceBegin) + 1;
  text.replace(from, end - from, table);
  std::ofstream(argv[2]) << text;
  return 0;
}
