#include "calib/line_source.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace standcal {

namespace {

constexpr std::size_t kBlockBytes = std::size_t{1} << 20;
constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";

std::string system_error_text(int error) { return std::strerror(error); }

}  // namespace

LineSource::LineSource(std::string_view text, int fd, std::string path)
    : path_(std::move(path)), fd_(fd), data_(text), total_(text.size()), end_of_input_(fd < 0) {}

LineSource LineSource::of_text(std::string_view text) { return LineSource(text, -1, {}); }

LineSource LineSource::of_file(const std::string& path, std::size_t begin) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(path + ": cannot open (" + system_error_text(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error(path + ": cannot open (a directory)");
  }
  LineSource source({}, fd, path);
  if (begin > 0) {
    if (::lseek(fd, static_cast<off_t>(begin), SEEK_SET) < 0)
      throw std::runtime_error(path + ": cannot seek (" + system_error_text(errno) + ")");
    source.consumed_before_ = begin;
    source.at_start_ = false;  // a byte order mark only opens a file
  }
  source.total_ = S_ISREG(st.st_mode) ? static_cast<std::size_t>(st.st_size) : 0;
  source.identity_ = {static_cast<unsigned long long>(st.st_dev),
                      static_cast<unsigned long long>(st.st_ino)};
  source.buffer_.resize(kBlockBytes);
  source.data_ = std::string_view(source.buffer_.data(), 0);
  return source;
}

LineSource::LineSource(LineSource&& other) noexcept
    : path_(std::move(other.path_)),
      fd_(std::exchange(other.fd_, -1)),
      buffer_(std::move(other.buffer_)),
      data_(other.data_),
      offset_(other.offset_),
      consumed_before_(other.consumed_before_),
      total_(other.total_),
      identity_(other.identity_),
      end_of_input_(other.end_of_input_),
      unterminated_(other.unterminated_),
      at_start_(other.at_start_),
      line_number_(other.line_number_) {
  // A moved std::string may move its bytes (short strings live inside it): re-point.
  if (fd_ >= 0) data_ = std::string_view(buffer_.data(), other.data_.size());
}

LineSource::~LineSource() {
  if (fd_ >= 0) ::close(fd_);
}

bool LineSource::refill() {
  if (end_of_input_) return false;
  const std::size_t tail = data_.size() - offset_;
  // A line longer than the buffer: grow it (only a pathological file does this).
  if (tail == buffer_.size()) buffer_.resize(buffer_.size() * 2);
  std::memmove(buffer_.data(), buffer_.data() + offset_, tail);
  consumed_before_ += offset_;
  std::size_t filled = tail;
  while (filled < buffer_.size()) {
    const ssize_t got = ::read(fd_, buffer_.data() + filled, buffer_.size() - filled);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0)
      throw std::runtime_error(path_ + ": read error (" + system_error_text(errno) + ")");
    if (got == 0) {
      end_of_input_ = true;
      break;
    }
    filled += static_cast<std::size_t>(got);
  }
  data_ = std::string_view(buffer_.data(), filled);
  offset_ = 0;
  return true;
}

bool LineSource::next(std::string_view& line) {
  while (true) {
    if (at_start_ && (data_.size() >= kByteOrderMark.size() || end_of_input_)) {
      if (data_.starts_with(kByteOrderMark)) offset_ = kByteOrderMark.size();
      at_start_ = false;
    }
    const std::size_t nl = at_start_ ? std::string_view::npos : data_.find('\n', offset_);
    if (nl != std::string_view::npos) {
      line = data_.substr(offset_, nl - offset_);
      offset_ = nl + 1;
      break;
    }
    if (refill()) continue;
    if (offset_ >= data_.size()) return false;
    line = data_.substr(offset_);
    offset_ = data_.size();
    unterminated_ = true;
    break;
  }
  ++line_number_;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return true;
}

}  // namespace standcal
