#pragma once
// Framing: one JSON object per line ('\n'; a preceding '\r' is dropped). Bytes arrive in
// arbitrary pieces; complete lines come out. A line longer than the limit is an error the
// reader must act on (the daemon answers it and closes the connection).
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace standcal::protocol {

class LineBuffer {
 public:
  explicit LineBuffer(std::size_t max_line_bytes) : max_(max_line_bytes) {}
  void append(std::string_view bytes) { buf_.append(bytes); }
  // The next complete line, without its newline; empty optional when none yet.
  std::optional<std::string> next_line();
  // True once the unfinished tail is longer than the limit (no newline in sight).
  bool overflowed() const;
  std::size_t pending_bytes() const { return buf_.size() - start_; }

 private:
  std::string buf_;
  std::size_t start_ = 0;
  std::size_t max_;
};

}  // namespace standcal::protocol
