#pragma once
// Test helpers that start real processes: the stand emulator (reading the URL it prints
// first) and a socat pty pair for RTU. Every process is killed when its object goes.
#include <sys/types.h>

#include <string>
#include <vector>

#include "tests/support/temp_dir.hpp"

namespace standcal::test {

// A child process; SIGTERM (then SIGKILL) and reaped on destruction.
class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv, bool capture_stdout = false);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  // First line of stdout (capture_stdout), waiting up to timeout_s; empty on timeout/exit.
  std::string read_line(double timeout_s);
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
};

// standcal-stand-emu started with `args` after --listen; url() is where it listens.
class EmulatorProcess {
 public:
  EmulatorProcess(const std::string& listen, const std::vector<std::string>& args);
  const std::string& url() const { return url_; }

 private:
  ChildProcess process_;
  std::string url_;
};

// Two linked pseudo-terminals from socat: bytes written to one arrive at the other,
// like the two ends of an RS-485 cable.
class PtyPair {
 public:
  explicit PtyPair(const std::string& directory);
  const std::string& emulator_end() const { return a_; }
  const std::string& driver_end() const { return b_; }
  bool ready() const { return ready_; }

 private:
  std::string a_, b_;
  ChildProcess socat_;
  bool ready_ = false;
};

}  // namespace standcal::test
