// Test helpers that start real processes (see emulator_process.hpp).
#include "emulator_process.hpp"

#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace standcal::test {

ChildProcess::ChildProcess(const std::vector<std::string>& argv, bool capture_stdout) {
  int pipe_fds[2] = {-1, -1};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (capture_stdout) {
    if (pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[1]);
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (capture_stdout) {
    close(pipe_fds[1]);
    stdout_fd_ = pipe_fds[0];
  }
  if (rc != 0) throw std::runtime_error("cannot start " + argv[0]);
}

ChildProcess::~ChildProcess() {
  if (stdout_fd_ >= 0) close(stdout_fd_);
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  for (int i = 0; i < 300; ++i) {
    if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
}

std::string ChildProcess::read_line(double timeout_s) {
  std::string line;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{stdout_fd_, POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    char c = 0;
    if (read(stdout_fd_, &c, 1) != 1) return {};
    if (c == '\n') return line;
    line += c;
  }
  return {};
}

EmulatorProcess::EmulatorProcess(const std::string& listen, const std::vector<std::string>& args)
    : process_(
          [&] {
            std::vector<std::string> argv{STANDCAL_STAND_EMU_PATH, "--listen", listen};
            argv.insert(argv.end(), args.begin(), args.end());
            return argv;
          }(),
          true),
      url_(process_.read_line(20.0)) {
  if (url_.empty()) throw std::runtime_error("the stand emulator did not print its URL");
}

PtyPair::PtyPair(const std::string& directory)
    : a_(directory + "/emu-tty"),
      b_(directory + "/drv-tty"),
      socat_({"socat", "pty,raw,echo=0,link=" + a_, "pty,raw,echo=0,link=" + b_}) {
  for (int i = 0; i < 500 && !ready_; ++i) {
    ready_ = std::filesystem::exists(a_) && std::filesystem::exists(b_);
    if (!ready_) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

}  // namespace standcal::test
