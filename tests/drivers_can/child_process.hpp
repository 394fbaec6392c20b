#pragma once
// Test helper: a child process (the emulator, the standcal CLI) started with one end
// of a socketpair as an inherited fd; killed and reaped when the test ends.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace standcal::drivers::can::testing {

class ChildProcess {
 public:
  // Starts `argv` with `inherit_fd` left open across exec; stdout goes to `stdout_fd`
  // when it is >= 0.
  ChildProcess(std::vector<std::string> argv, int inherit_fd, int stdout_fd = -1) {
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      fcntl(inherit_fd, F_SETFD, 0);  // clear FD_CLOEXEC: the child inherits it
      if (stdout_fd >= 0) dup2(stdout_fd, STDOUT_FILENO);
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Waits up to timeout_s for the exit; returns the exit code, or -1 (then kills it).
  int wait_exit(double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
};

}  // namespace standcal::drivers::can::testing
