// Running the rangeseg command-line tool from tests (RANGESEG_CLI is its path).
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace rangeseg::test {

struct CliResult {
  int code = -1;
  std::string out;  ///< stdout and stderr together
};

/// Runs `rangeseg ARGS` through the shell and returns its exit code and output.
inline CliResult run_cli(const std::string& args) {
  const std::string cmd = std::string(RANGESEG_CLI) + " " + args + " 2>&1";
  CliResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  while (const std::size_t n = fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace rangeseg::test
