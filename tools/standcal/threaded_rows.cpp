#include "tools/standcal/threaded_rows.hpp"

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

RecordingDigest digest_on_two_threads(const std::string& path, const DigestOptions& options) {
  RecordingDigester digester(options);
  ThreadedRows rows(digester);
  Recording read;
  try {
    read = stream_recording(path, rows);
  } catch (...) {
    rows.fail_after_reader_error();
  }
  rows.finish();
  // What the reader warned about is said even when the digest then fails: "no samples"
  // means more beside "the last line was cut off mid-write".
  const std::vector<std::string> warnings = read.warnings;
  try {
    return digester.finish(std::move(read));
  } catch (...) {
    print_warnings(warnings);
    throw;
  }
}

}  // namespace standcal::cli
