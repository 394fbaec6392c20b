#pragma once
// A diagnosis runs in a child process (`standcald --diagnose-worker`), never in the process
// that drives the stand: whatever the maths does on a strange recording (a crash, a runaway
// allocation, a hang), the daemon answers with an error and keeps serving the stand, its
// runs and `estop` (issue 14: an empty QR once segfaulted the daemon mid-run, and the axes
// moved on until the controller's heartbeat stopped them).
//
// The job goes to the child's stdin as one JSON object {run_status, limits, report}; the
// child writes {"result": ...} or {"error": {code, message}} on its stdout and exits 0. The
// child runs at a lower priority (nice 10), with a CPU-time limit, a memory limit (not
// under the sanitizers, which reserve terabytes of address space) and dies with its parent.
#include <sys/types.h>
#include <atomic>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/noise_model.hpp"
#include "calib/programs.hpp"

namespace standcal::daemon {

inline constexpr const char* kDiagnoseWorkerFlag = "--diagnose-worker";
// A diagnosis of a 1-hour recording takes about a second; this is for a runaway one.
inline constexpr double kDiagnoseWorkerTimeout_s = 600;
// Fault injection for the tests (docs/reliability.md): "abort" makes the child abort
// after reading its job, as a crash in the maths would.
inline constexpr const char* kDiagnoseWorkerFaultEnv = "STANDCALD_FAULT_DIAGNOSE_WORKER";

struct DiagnoseJob {
  nlohmann::json run_status;  // the run's run.status: run_id, recording_path, unit_serial, ...
  StandLimits limits;         // the configured stand's ranges (proposed positions lie inside)
  GivenWander unit_wander;    // the configured one: for a recording whose header has none
  bool with_report = false;
};

// Runs `job` in a child of `exe` (`exe --diagnose-worker`) and returns its answer. Throws
// protocol::RpcError: the child's own error, or -32603 when the child died, was stopped
// after `timeout_s` or answered nothing readable (the message names the run and the
// signal). `child_pid` holds the child's pid while it runs (0 otherwise), so a shutdown can
// stop it.
nlohmann::json diagnose_in_child(const DiagnoseJob& job, const std::string& exe, double timeout_s,
                                 std::atomic<pid_t>& child_pid);

// The child's side: one job from stdin, its answer on stdout. Returns the exit status.
int diagnose_worker_main();

}  // namespace standcal::daemon
