#include "tools/standcal/threaded_rows.hpp"

#include <atomic>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tools/standcal/input_options.hpp"

namespace standcal::cli {

namespace {
constexpr std::size_t kBatchRows = 4096;  // 0.4 MB of rows per hand-over
constexpr std::size_t kQueuedBatches = 2;
}  // namespace

ThreadedRows::ThreadedRows(RecordingRowSink& reducer) : reducer_(reducer) {
  batch_.reserve(kBatchRows);
  worker_ = std::thread([this] { reduce_batches(); });
}

ThreadedRows::~ThreadedRows() { stop_and_join(); }

void ThreadedRows::header(const Recording& rec) { reducer_.header(rec); }

void ThreadedRows::row(const RecordingSample& sample) {
  batch_.push_back(sample);
  if (batch_.size() == kBatchRows) hand_over();
}

void ThreadedRows::expect_rows(std::size_t rows) {
  std::lock_guard lock(mutex_);
  expected_rows_ = rows;
}

void ThreadedRows::hand_over() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return queue_.size() < kQueuedBatches || reducer_error_; });
  if (reducer_error_) std::rethrow_exception(reducer_error_);  // stop reading a failed file
  queue_.push_back(std::move(batch_));
  batch_ = {};
  batch_.reserve(kBatchRows);
  changed_.notify_all();
}

void ThreadedRows::reduce_batches() {
  while (true) {
    std::vector<RecordingSample> batch;
    std::size_t expected_rows = 0;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [this] { return !queue_.empty() || done_; });
      if (queue_.empty()) return;
      batch = std::move(queue_.front());
      expected_rows = std::exchange(expected_rows_, 0);
      queue_.pop_front();
      changed_.notify_all();
    }
    try {
      if (expected_rows > 0) reducer_.expect_rows(expected_rows);
      for (const RecordingSample& s : batch) reducer_.row(s);
    } catch (...) {
      std::lock_guard lock(mutex_);
      reducer_error_ = std::current_exception();
      queue_.clear();
      changed_.notify_all();
      return;
    }
  }
}

void ThreadedRows::stop_and_join() {
  {
    std::lock_guard lock(mutex_);
    done_ = true;
    changed_.notify_all();
  }
  if (worker_.joinable()) worker_.join();
}

void ThreadedRows::finish() {
  if (!batch_.empty()) hand_over();
  stop_and_join();
  if (reducer_error_) std::rethrow_exception(reducer_error_);
}

void ThreadedRows::fail_after_reader_error() {
  const std::exception_ptr reader_error = std::current_exception();
  {
    std::lock_guard lock(mutex_);
    if (!batch_.empty() && !reducer_error_) queue_.push_back(std::move(batch_));
  }
  stop_and_join();  // the queued rows precede the failing line
  if (reducer_error_) std::rethrow_exception(reducer_error_);
  std::rethrow_exception(reader_error);
}

namespace {

// How far past the middle the second part's first dwell is looked for, line by line: a
// dwell longer than this (a static recording of one position) is read the one-part way,
// after 6.2-6.6 ms of looking (docs/performance.md).
constexpr std::size_t kDwellSearchBytes = std::size_t{8} << 20;

// The digest, with the reader's warnings printed when it fails: "no samples" means more
// beside "the last line was cut off mid-write".
RecordingDigest finish_digest(RecordingDigester& digester, Recording&& read) {
  const std::vector<std::string> warnings = read.warnings;
  try {
    return digester.finish(std::move(read));
  } catch (...) {
    print_warnings(warnings);
    throw;
  }
}

// The rows from where `reader` stopped, parsed here and reduced on a second thread.
Recording read_rest_threaded(RecordingReader& reader, RecordingDigester& digester) {
  ThreadedRows rows(digester);
  try {
    reader.read_rows(rows);
  } catch (...) {
    rows.fail_after_reader_error();
  }
  rows.finish();
  return reader.finish();
}

// Runs `part` on a second thread; the destructor cancels and joins it when the first part
// failed (a file read in order stops at its first error).
class PartThread {
 public:
  PartThread(RecordingPartReader& part, RecordingDigester& digester)
      : thread_([this, &part, &digester] {
          read_ = part.read(digester, cancel_);
          if (!read_) return;
          try {
            digester.close_dwell();
          } catch (...) {
            read_ = false;  // told again, with its line, when read in order
          }
        }) {}
  ~PartThread() {
    cancel_ = true;
    if (thread_.joinable()) thread_.join();
  }
  PartThread(const PartThread&) = delete;
  PartThread& operator=(const PartThread&) = delete;
  bool join() {
    thread_.join();
    return read_;
  }

 private:
  std::atomic<bool> cancel_{false};
  bool read_ = false;
  std::thread thread_;
};

}  // namespace

RecordingDigest digest_on_two_threads(const std::string& path, const DigestOptions& options) {
  RecordingDigester digester(options);
  RecordingReader reader(path);
  const Recording& head = reader.read_header(digester);
  const std::size_t size = reader.bytes_total();
  const std::optional<std::size_t> split =
      digester.rate_known() && size >= kTwoPartBytes
          ? reader.dwell_start_after(size / 2, kDwellSearchBytes)
          : std::nullopt;
  if (!split) return finish_digest(digester, read_rest_threaded(reader, digester));

  RecordingDigester later(options);
  later.header(head);
  later.keep_for_append();
  RecordingPartReader part = reader.part_from(*split);
  bool part_read = false;
  {
    PartThread thread(part, later);
    reader.read_rows(digester, *split);
    part_read = thread.join();
  }
  if (part_read && reader.continues_with(part)) {
    digester.append(std::move(later));
    return finish_digest(digester, reader.finish());
  }
  // The part had an error, or does not follow on: read it in order, as one reader would.
  return finish_digest(digester, read_rest_threaded(reader, digester));
}

}  // namespace standcal::cli
