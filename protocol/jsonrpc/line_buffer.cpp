#include "protocol/jsonrpc/line_buffer.hpp"

namespace standcal::protocol {

std::optional<std::string> LineBuffer::next_line() {
  const std::size_t nl = buf_.find('\n', start_);
  if (nl == std::string::npos) {
    // Compact once everything before start_ is consumed, so the buffer does not grow.
    buf_.erase(0, start_);
    start_ = 0;
    return std::nullopt;
  }
  std::size_t end = nl;
  if (end > start_ && buf_[end - 1] == '\r') --end;
  std::string line = buf_.substr(start_, end - start_);
  start_ = nl + 1;
  return line;
}

bool LineBuffer::overflowed() const {
  const std::size_t nl = buf_.find('\n', start_);
  const std::size_t line_len = (nl == std::string::npos ? buf_.size() : nl) - start_;
  return line_len > max_;
}

}  // namespace standcal::protocol
