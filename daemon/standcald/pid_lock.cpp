#include "daemon/standcald/pid_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>

#include "daemon/standcald/errno_text.hpp"

namespace standcal::daemon {

namespace {

std::string pid_in(int fd) {
  char buf[32] = {};
  if (::pread(fd, buf, sizeof buf - 1, 0) <= 0) return {};
  const std::string text(buf);
  return text.substr(0, text.find('\n'));
}

}  // namespace

PidLock::PidLock(const std::string& path, const HeldByAnother& held_by_another) {
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
  if (fd_ < 0) throw std::runtime_error("cannot open the lock file " + path + ": " + errno_text());
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const bool held = errno == EWOULDBLOCK;
    const std::string why =
        held ? held_by_another(pid_in(fd_)) : "cannot lock " + path + ": " + errno_text();
    ::close(fd_);
    throw std::runtime_error(why);
  }
  // For the message above, and for an operator wondering who holds it.
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) < 0) {
    const std::string why = errno_text();
    ::close(fd_);
    throw std::runtime_error("cannot write " + path + ": " + why);
  }
}

PidLock::~PidLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

}  // namespace standcal::daemon
