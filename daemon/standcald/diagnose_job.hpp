#pragma once
// `run.diagnose` {run_id, report?}: the model-mismatch diagnosis
// (calib/diagnosis/diagnosis.hpp) of a run's recording, in the shape of `standcal diagnose
// --json`. A diagnosis takes seconds,
// so it never runs on the socket thread: requests are checked there (a bad one is answered
// at once), then one worker thread hands them in turn to a child process
// (diagnose_worker.hpp: a crash in the maths never takes the daemon down) and passes each
// answer to the reply function, which posts it back to the socket thread (as the
// sequencer's replies do).
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "daemon/standcald/diagnose_worker.hpp"
#include "daemon/standcald/sequencer.hpp"

namespace standcal::daemon {

// Past this many waiting diagnoses a request gets `busy` (the bench PC has few cores).
inline constexpr std::size_t kMaxQueuedDiagnoses = 4;
// A report larger than this is not sent over the socket (a client's queue holds 1 MiB).
inline constexpr std::size_t kMaxReportBytes = 768 * 1024;

// The answer for one run: `run_status` is the run's `run.status` (its recording_path,
// unit_serial, run_id); proposed positions lie inside `limits` (the configured stand's). The
// unit's wander is the one the recording's header says the run was made with (its fits'); for
// a recording whose header has none, `configured`; neither, its own long dwell's.
// Throws protocol::RpcError with the code the protocol gives (-32603 unreadable
// recording, -32007 a recording that cannot be diagnosed). The answer without the report
// is also kept as diagnosis.json beside the recording (`saved_path`; null with
// `save_error` when the disk refused it: the answer is still given).
nlohmann::json diagnose_run(const nlohmann::json& run_status, const StandLimits& limits,
                            const GivenWander& configured, bool with_report);

class DiagnoseJobs {
 public:
  // `worker_exe` is the program run as `worker_exe --diagnose-worker`: standcald itself.
  explicit DiagnoseJobs(std::string worker_exe = "/proc/self/exe");
  // Stops the diagnosis in progress (its child is killed, its answer dropped); queued
  // ones are dropped.
  ~DiagnoseJobs();
  DiagnoseJobs(const DiagnoseJobs&) = delete;
  DiagnoseJobs& operator=(const DiagnoseJobs&) = delete;

  // Checks `params` and the run now (throws protocol::RpcError: -32602 bad params, -32006
  // no such run, -32007 run still in progress or nothing recorded, -32001 too many
  // waiting); then queues the diagnosis. `reply` is called once, on the worker thread.
  void submit(const Sequencer& sequencer, const nlohmann::json& params, ReplyFn reply);

 private:
  struct Job {
    DiagnoseJob job;
    ReplyFn reply;
  };
  void worker_main();

  std::string worker_exe_;
  std::atomic<pid_t> child_pid_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace standcal::daemon
