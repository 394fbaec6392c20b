#pragma once
// Two cores, two jobs: the reader parses rows on the calling thread while a second thread
// reduces them (averages, Allan deviation), so the reduction is off the critical path.
// Rows travel in batches through a queue of at most two, which bounds the memory.
//
// Errors come out as the one-thread reading would raise them: rows reach the reducer in
// file order, and when the reader fails, the batches before the failing line are reduced
// first and a reducer error among them wins (it is about earlier lines).
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "calib/recording.hpp"
#include "calib/recording_digest.hpp"

namespace standcal::cli {

class ThreadedRows : public RecordingRowSink {
 public:
  explicit ThreadedRows(RecordingRowSink& reducer);
  ~ThreadedRows() override;
  ThreadedRows(const ThreadedRows&) = delete;
  ThreadedRows& operator=(const ThreadedRows&) = delete;

  void header(const Recording& rec) override;  // on the caller's thread, before any row
  void row(const RecordingSample& sample) override;
  // Passed to the reducer on its thread, before the next batch it reduces.
  void expect_rows(std::size_t rows) override;
  // Waits until every row is reduced; rethrows the reducer's error.
  void finish();
  // After the reader threw: waits for the rows before the failure, then rethrows the
  // reducer's error if it had one, else the reader's (the current exception).
  [[noreturn]] void fail_after_reader_error();

  static constexpr int kThreads = 2;

 private:
  void hand_over();
  void reduce_batches();
  void stop_and_join();

  RecordingRowSink& reducer_;
  std::vector<RecordingSample> batch_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::vector<RecordingSample>> queue_;
  bool done_ = false;
  std::size_t expected_rows_ = 0;  // a hint not yet passed on (0: none)
  std::exception_ptr reducer_error_;
  std::thread worker_;
};

// Files at least this long whose rate is known before the rows (the header's, or --rate-hz)
// are read in two parts at once.
inline constexpr std::size_t kTwoPartBytes = std::size_t{4} << 20;

// digest_recording on two threads: a file of kTwoPartBytes or more, with its sample rate
// in the header or the options, in two parts at once, each parsed and reduced by its own thread
// (the second part begins with a dwell, found after the middle of the file); any other with the
// parsing on this thread and the reduction on a second (ThreadedRows).
RecordingDigest digest_on_two_threads(const std::string& path, const DigestOptions& options);

}  // namespace standcal::cli
