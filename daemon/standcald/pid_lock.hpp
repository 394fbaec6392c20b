#pragma once
// An exclusive flock on a file that holds the holder's pid, kept for the object's life.
// The kernel drops the lock on any exit (SIGKILL included), so a crash leaves no stale
// lock; the file itself stays, since removing it would race with the next holder. Used
// for what one standcald must own alone: its state directory and its socket path.
#include <functional>
#include <string>

namespace standcal::daemon {

class PidLock {
 public:
  // Message for a lock another process holds, given that holder's pid ("" when the file
  // does not say).
  using HeldByAnother = std::function<std::string(const std::string& holder_pid)>;
  // Takes the lock on `path` (creating the file) or throws std::runtime_error.
  PidLock(const std::string& path, const HeldByAnother& held_by_another);
  ~PidLock();
  PidLock(PidLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  PidLock(const PidLock&) = delete;
  PidLock& operator=(const PidLock&) = delete;
  PidLock& operator=(PidLock&&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace standcal::daemon
