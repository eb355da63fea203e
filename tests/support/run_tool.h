#pragma once

// Runs a command line through the shell and keeps what it printed, for the tool tests.

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace hyq::test {

struct ToolRun {
  int exit_code = -1;  // the exit status, or 128 + the signal that ended it
  std::string out;     // stdout and stderr
};

// `tool` `args` with stderr joined to stdout.
inline ToolRun RunTool(const std::string& tool, const std::string& args) {
  ToolRun r;
  const std::string cmd = tool + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf;
  size_t got;
  while ((got = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), got);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

}  // namespace hyq::test
