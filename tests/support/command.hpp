#pragma once
// Runs a command line as an operator would (through the shell, stderr joined to stdout),
// for tests of the real command-line tools: what they print and their exit code.
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace standcal::test {

struct CommandOutcome {
  int exit_code = -1;  // -1: could not be started, or killed by a signal
  std::string output;  // stdout and stderr
};

inline CommandOutcome run_command(const std::string& command_line) {
  CommandOutcome r;
  std::FILE* pipe = ::popen((command_line + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) r.output.append(buf, n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

#ifdef STANDCAL_CLI_PATH
// `standcal ARGS` of this build (the test target defines STANDCAL_CLI_PATH).
inline CommandOutcome standcal_cli(const std::string& args) {
  return run_command(std::string(STANDCAL_CLI_PATH) + " " + args);
}
#endif

}  // namespace standcal::test
