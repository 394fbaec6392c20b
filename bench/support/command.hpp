#pragma once
// Runs a command as a user would (its own process, stdout to /dev/null) and measures it:
// the median wall time of several runs and the largest peak resident memory (wait4's
// ru_maxrss, the child's own, so no other process's peak can hide in it).
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/support/timing.hpp"

namespace standcal::bench {

struct CommandFigures {
  double median_s = 0;
  double peak_rss_mib = 0;
};

// `is_answer`: whether an exit status is an answer, not a failure (a diagnosis verdict is
// 4 or 5: protocol/jsonrpc/exit_codes.hpp, is_diagnosis_answer).
inline bool is_success(int status) { return status == 0; }

inline CommandFigures measure_command(const std::vector<std::string>& argv, int repeats,
                                      bool (*is_answer)(int) = is_success) {
  std::vector<double> wall_s;
  long peak_kib = 0;
  for (int i = 0; i < repeats; ++i) {
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const auto start = Clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
      const int null_fd = ::open("/dev/null", O_WRONLY);
      ::dup2(null_fd, STDOUT_FILENO);
      ::execvp(args[0], args.data());
      ::_exit(127);
    }
    int status = 0;
    rusage usage{};
    if (::wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) ||
        !is_answer(WEXITSTATUS(status)))
      throw std::runtime_error(argv[0] + " " + (argv.size() > 1 ? argv[1] : "") + " failed (" +
                               (WIFEXITED(status)
                                    ? "exit status " + std::to_string(WEXITSTATUS(status))
                                    : std::string("killed by a signal")) +
                               ")");
    wall_s.push_back(seconds_of(start));
    peak_kib = std::max(peak_kib, usage.ru_maxrss);
  }
  return {median(wall_s), static_cast<double>(peak_kib) / 1024.0};
}

}  // namespace standcal::bench
