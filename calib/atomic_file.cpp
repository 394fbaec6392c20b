#include "calib/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace standcal {
namespace {

std::string errno_text(const char* step) { return std::string(step) + ": " + std::strerror(errno); }

// Into an existing device or pipe; empty, or what went wrong.
std::string write_in_place(const std::string& path, std::string_view text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return errno_text("open");
  std::string why = write_fully(fd, text) ? "" : errno_text("write");
  if (::close(fd) != 0 && why.empty()) why = errno_text("close");
  return why;
}

// PATH.tmp written, flushed to the disk and renamed over `path`; empty, or what went wrong.
std::string replace(const std::string& path, std::string_view text, mode_t mode) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, mode);
  if (fd < 0) return errno_text(("create " + tmp).c_str());
  std::string why = !write_fully(fd, text) ? errno_text("write")
                    : ::fsync(fd) != 0     ? errno_text("fsync")
                                           : "";
  if (::close(fd) != 0 && why.empty()) why = errno_text("close");
  if (why.empty() && ::rename(tmp.c_str(), path.c_str()) != 0) why = errno_text("rename");
  if (!why.empty()) ::unlink(tmp.c_str());
  return why;
}

}  // namespace

bool write_fully(int fd, std::string_view text) {
  while (!text.empty()) {
    const ssize_t n = ::write(fd, text.data(), text.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    text.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

void fsync_directory(const std::string& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

void write_file_atomically(const std::string& path, std::string_view text, const std::string& what,
                           mode_t mode) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  std::string why;
  if (fs::is_directory(status)) {
    why = "it is a directory";
  } else if (fs::exists(status) && !fs::is_regular_file(status)) {
    why = write_in_place(path, text);
  } else {
    why = replace(path, text, mode);
    if (why.empty()) fsync_directory(fs::path(path).parent_path().string());
  }
  if (!why.empty()) throw std::runtime_error(path + ": could not write " + what + " (" + why + ")");
}

}  // namespace standcal
