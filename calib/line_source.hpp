#pragma once
// The lines of a recording, from text in memory or from a file read in fixed blocks: the
// readers' one way to walk their input, so that reading a file never holds it whole (a
// one-hour, 100 Hz recording is 40 MB; the block is 1 MiB).
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>

namespace standcal {

class LineSource {
 public:
  // Lines of `text` (not copied: it must outlive the source).
  static LineSource of_text(std::string_view text);
  // Lines of the file at `path`; throws std::runtime_error "<path>: cannot open (...)".
  // From byte `begin` on when given (a line start, or the rest of a line is the first
  // "line"); bytes_consumed() then counts from the file's start, line_number() from begin.
  static LineSource of_file(const std::string& path, std::size_t begin = 0);

  LineSource(LineSource&& other) noexcept;
  LineSource& operator=(LineSource&&) = delete;
  LineSource(const LineSource&) = delete;
  ~LineSource();

  // The next line without its '\n' and without a trailing '\r'; false at the end. The view
  // stays valid until the next call. A UTF-8 byte order mark before the first line is not
  // part of it (spreadsheet tools write one).
  bool next(std::string_view& line);
  // The line `next` returned last ended the input without a '\n' (a run cut off mid-write).
  bool unterminated() const { return unterminated_; }
  // 1-based number of the line `next` returned last (0 before the first).
  int line_number() const { return line_number_; }
  // Bytes of input passed so far, and in all (for a file: its size when opened), so that
  // a reader can size its storage once instead of growing it by copies.
  std::size_t bytes_consumed() const { return consumed_before_ + offset_; }
  std::size_t bytes_total() const { return total_; }
  // The file's device and inode (both 0 for text in memory): whether two sources opened by
  // name read the same file, not one that replaced it meanwhile (a rename over the path).
  std::pair<unsigned long long, unsigned long long> file_identity() const { return identity_; }

 private:
  LineSource(std::string_view text, int fd, std::string path);
  // Moves the unread tail to the front of the buffer and reads more; false at end of file.
  bool refill();

  std::string path_;
  int fd_ = -1;            // -1: text in memory
  std::string buffer_;     // file blocks (empty for text in memory)
  std::string_view data_;  // the bytes available: the text, or the filled part of buffer_
  std::size_t offset_ = 0;
  std::size_t consumed_before_ = 0;  // bytes dropped from the buffer by refills
  std::size_t total_ = 0;
  std::pair<unsigned long long, unsigned long long> identity_{0, 0};
  bool end_of_input_ = false;
  bool unterminated_ = false;
  bool at_start_ = true;
  int line_number_ = 0;
};

}  // namespace standcal
