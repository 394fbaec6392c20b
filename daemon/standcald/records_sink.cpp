#include "daemon/standcald/records_sink.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>

#include "records/db/records_db.hpp"

namespace standcal::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

RecordsSink::RecordsSink(std::string state_dir, std::string db_url, double retry_interval_s)
    : state_dir_(std::move(state_dir)),
      db_url_(db_url.empty() ? records::default_db_url(state_dir_) : std::move(db_url)),
      retry_interval_s_(retry_interval_s) {}

RecordsSink::~RecordsSink() { stop(); }

void RecordsSink::start() {
  if (thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
    woken_ = true;  // the first pass runs at once
  }
  thread_ = std::thread([this] { loop(); });
}

void RecordsSink::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RecordsSink::on_event(const std::string& event, const json& params) {
  if (event == "run.state" && params.is_object() && params.value("state", "") == "done") wake();
}

void RecordsSink::wake() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
  }
  wake_cv_.notify_all();
}

RecordsSyncReport RecordsSink::last_report() const {
  std::lock_guard lock(mutex_);
  return report_;
}

void RecordsSink::loop() {
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      // Sleeps until a run finishes; while results are pending, retries every interval.
      const bool pending = report_.pending > 0 || !report_.error.empty();
      const auto wait = std::chrono::duration<double>(pending ? retry_interval_s_ : 3600.0);
      wake_cv_.wait_for(lock, wait, [this] { return woken_ || stopping_; });
      if (stopping_) return;
      woken_ = false;
    }
    sync_once();
  }
}

std::vector<std::string> RecordsSink::unrecorded_runs() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path(state_dir_) / "runs", ec)) {
    const std::string id = entry.path().filename().string();
    if (recorded_.count(id) == 0 && fs::exists(entry.path() / "result.json")) out.push_back(id);
  }
  std::sort(out.begin(), out.end());  // run ids start with their UTC stamp
  return out;
}

void RecordsSink::connect() {
  if (db_) return;
  db_ = records::open_and_migrate(db_url_);
  spdlog::info("records database {} (schema {})", db_->location(), db_->schema_version());
}

records::CalibrationRecord RecordsSink::record_of_run(const std::string& run_id) const {
  const std::string path = (fs::path(state_dir_) / "runs" / run_id / "result.json").string();
  std::ifstream in(path);
  const json result = json::parse(in, nullptr, false);
  if (result.is_discarded() || !result.is_object())
    throw std::runtime_error("run " + run_id + ": cannot parse " + path);
  records::CalibrationRecord record = records::record_from_daemon_result(result);
  if (record.run_id.empty()) record.run_id = run_id;
  if (record.unit_serial.empty())
    throw std::runtime_error("run " + run_id + ": " + path + " names no unit serial");
  record.started_utc = records::canonical_utc(record.started_utc);
  if (!record.ended_utc.empty()) record.ended_utc = records::canonical_utc(record.ended_utc);
  return record;
}

RecordsSyncReport RecordsSink::sync_once() {
  std::lock_guard sync_lock(sync_mutex_);
  RecordsSyncReport report;
  const std::vector<std::string> todo = unrecorded_runs();
  report.pending = static_cast<int>(todo.size());
  for (const std::string& run_id : todo) {
    records::CalibrationRecord record;
    try {
      record = record_of_run(run_id);
    } catch (const std::exception& e) {
      // A result the database cannot take stays pending (and named) without holding
      // back the runs after it.
      report.error = e.what();
      continue;
    }
    try {
      connect();
      if (db_->insert(record)) {
        ++report.recorded;
        spdlog::info("run {}: recorded in {}", run_id, db_->location());
      } else {
        ++report.already_present;
      }
      recorded_.insert(run_id);
      --report.pending;
    } catch (const std::exception& e) {
      // The result stays in the state directory; the next pass tries again on a new
      // connection.
      report.error = std::string("run ") + run_id + " not yet in the records database: " + e.what();
      db_.reset();
      break;
    }
  }
  if (!report.error.empty())
    spdlog::warn("{} ({} pending; retrying in {} s)", report.error, report.pending,
                 retry_interval_s_);
  std::lock_guard lock(mutex_);
  report_ = report;
  return report;
}

}  // namespace standcal::daemon
