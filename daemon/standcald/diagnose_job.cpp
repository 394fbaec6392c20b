#include "daemon/standcald/diagnose_job.hpp"

#include <signal.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "calib/allan.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/json_text.hpp"
#include "calib/recording.hpp"
#include "daemon/standcald/diagnose_worker.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "report/diagnosis/diagnosis_report.hpp"

namespace standcal::daemon {

using nlohmann::json;
using protocol::ErrorCode;
using protocol::RpcError;

namespace {

bool in_progress(const std::string& state) {
  namespace rs = protocol::run_state;
  return state == rs::running || state == rs::waiting_operator;
}

// The mount the recording starts on: proposed positions are poses on that mount.
std::string first_mount(const Recording& rec) {
  if (!rec.samples.empty() && rec.samples.front().mount)
    return mount_name(*rec.samples.front().mount);
  return mount_name(rec.default_mount.value_or(Mount::x));
}

// The diagnosis is kept with the run (runs/<id>/diagnosis.json) so the lab has it after the
// answer is gone; a full disk costs the copy, not the answer.
void save_beside_recording(json& out, const std::string& recording_path) {
  const std::string saved =
      (std::filesystem::path(recording_path).parent_path() / "diagnosis.json").string();
  try {
    out["saved_path"] = saved;
    write_state_file(saved, json_text(out) + "\n");
  } catch (const std::exception& e) {
    out["saved_path"] = nullptr;
    out["save_error"] = e.what();
    spdlog::warn("run.diagnose: {}", e.what());
  }
}

}  // namespace

json diagnose_run(const json& run_status, const StandLimits& limits, const GivenWander& configured,
                  bool with_report) {
  const std::string run_id = run_status.value("run_id", "");
  const std::string path = run_status.value("recording_path", "");
  Recording rec;
  try {
    rec = read_recording(path);
  } catch (const std::exception& e) {
    throw RpcError(ErrorCode::internal_error,
                   "run " + run_id + ": the stored recording cannot be read: " + e.what());
  }
  Diagnosis d;
  try {
    DiagnoseOptions options;
    options.limits = limits;
    if (header_silent_on_unit_wander(rec)) {  // a recording from before headers carried it
      options.specified_wander = configured.specified();
      options.known_tau = configured.known_tau;
    }
    d = diagnose_recording(rec, options);
  } catch (const std::exception& e) {
    throw RpcError(ErrorCode::invalid_state,
                   "run " + run_id + ": its recording cannot be diagnosed: " + e.what());
  }
  json out = diagnose_to_json(d);
  out["run_id"] = run_id;
  out["unit_serial"] = run_status.value("unit_serial", "");
  out["unit_type"] = run_status.value("unit_type", "");
  out["recording_path"] = path;
  out["mount"] = first_mount(rec);
  out["recording_warnings"] = rec.warnings;
  if (std::string why = no_sample_period_warning(rec); !why.empty())
    out["recording_warnings"].push_back(std::move(why));
  save_beside_recording(out, path);
  if (with_report) {
    std::string html = report::diagnosis_html(d, rec);
    if (html.size() > kMaxReportBytes) {
      out["report_html"] = nullptr;
      out["report_note"] =
          "the report is " + std::to_string(html.size() / 1024) +
          " KiB, too large to send; make it where the recording is readable: standcal diagnose " +
          path + " --report FILE";
    } else {
      out["report_html"] = std::move(html);
    }
  }
  return out;
}

namespace {

Outcome outcome_of(const DiagnoseJob& job, const std::string& worker_exe,
                   std::atomic<pid_t>& child_pid) {
  Outcome o;
  try {
    o.result = diagnose_in_child(job, worker_exe, kDiagnoseWorkerTimeout_s, child_pid);
  } catch (const RpcError& e) {
    o.error_code = e.code();
    o.error_message = e.what();
  } catch (const std::exception& e) {
    o.error_code = static_cast<int>(ErrorCode::internal_error);
    o.error_message =
        "run " + job.run_status.value("run_id", "") + ": diagnosis failed: " + e.what();
  }
  return o;
}

}  // namespace

DiagnoseJobs::DiagnoseJobs(std::string worker_exe)
    : worker_exe_(std::move(worker_exe)), worker_([this] { worker_main(); }) {}

DiagnoseJobs::~DiagnoseJobs() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    queue_.clear();
  }
  // A shutdown does not wait for a diagnosis: its child goes (the answer had nobody to go to).
  if (const pid_t pid = child_pid_.load(); pid > 0) ::kill(pid, SIGKILL);
  wake_.notify_all();
  worker_.join();
}

void DiagnoseJobs::submit(const Sequencer& sequencer, const json& params, ReplyFn reply) {
  const auto request = protocol::RunDiagnoseParams::parse(params);
  const std::string& run_id = request.run_id;
  const bool with_report = request.report;
  const protocol::RunStatusResult status = sequencer.run_status(run_id);  // -32006: unknown run
  const std::string& state = status.state;
  if (in_progress(state)) {
    throw RpcError(ErrorCode::invalid_state, "run " + run_id + " is " + state +
                                                 "; diagnose it when it has ended (or pause it)");
  }
  if (status.positions_done == 0) {
    throw RpcError(ErrorCode::invalid_state,
                   "run " + run_id + " has no recorded position to diagnose");
  }
  std::lock_guard lock(mutex_);
  if (queue_.size() >= kMaxQueuedDiagnoses) {
    throw RpcError(ErrorCode::busy,
                   std::to_string(queue_.size()) + " diagnoses are waiting; try again shortly");
  }
  queue_.push_back({{json(status), sequencer.stand_limits(), sequencer.unit_wander(), with_report},
                    std::move(reply)});
  wake_.notify_one();
}

void DiagnoseJobs::worker_main() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    Job job = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    const auto started = std::chrono::steady_clock::now();
    Outcome o = outcome_of(job.job, worker_exe_, child_pid_);
    spdlog::info("run.diagnose {}: {} in {:.1f} s", job.job.run_status.value("run_id", ""),
                 o.error_code == 0 ? o.result.value("verdict", "?") : o.error_message,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    lock.lock();
    if (stopping_) return;    // the server is going away: nobody to answer
    job.reply(std::move(o));  // under the lock, so the destructor cannot pass it
  }
}

}  // namespace standcal::daemon
