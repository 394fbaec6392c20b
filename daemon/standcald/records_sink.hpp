#pragma once
// Records every finished run in the lab's records database (docs/records.md), without
// ever losing one: the state directory (recording + result.json) stays the source of
// truth, and the sink only copies from it. A run whose result is not in the database yet
// is pending; the sink tries again on every finished run, every retry interval, and at
// start (so results from a time the database was down, or from before it existed, are
// recorded). Inserting is idempotent (a run id already stored is left alone), so trying
// twice is harmless.
//
// Hook: the daemon forwards the sequencer's events to on_event(); "run.state" with state
// "done" wakes the sink at once. The sink never blocks its caller.
#include <condition_variable>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "records/db/records_db.hpp"

namespace standcal::daemon {

struct RecordsSyncReport {
  int recorded = 0;         // newly stored in this pass
  int already_present = 0;  // stored before (by this or another run of the sink)
  int pending = 0;          // finished runs still not in the database
  std::string error;        // why the last attempt failed ("" after a good pass)
};

class RecordsSink {
 public:
  // `db_url` empty: SQLite in the state directory (records::default_db_url).
  RecordsSink(std::string state_dir, std::string db_url, double retry_interval_s = 30);
  ~RecordsSink();
  RecordsSink(const RecordsSink&) = delete;
  RecordsSink& operator=(const RecordsSink&) = delete;

  // Starts the background thread; its first pass records whatever is pending.
  void start();
  // Stops the thread (also done by the destructor).
  void stop();
  // The sequencer's events; a finished run wakes the sink. Never blocks.
  void on_event(const std::string& event, const nlohmann::json& params);
  // Wakes the sink now (e.g. an operator's "retry").
  void wake();

  // One pass in the caller's thread: every finished run not yet stored is stored.
  // Never throws; the report says what happened.
  RecordsSyncReport sync_once();
  RecordsSyncReport last_report() const;
  const std::string& db_url() const { return db_url_; }

 private:
  void loop();
  // Finished runs (with result.json) the sink has not stored yet, oldest first.
  std::vector<std::string> unrecorded_runs() const;
  void connect();
  // The database record of a finished run, from its result.json; throws naming the file.
  records::CalibrationRecord record_of_run(const std::string& run_id) const;

  std::string state_dir_;
  std::string db_url_;
  double retry_interval_s_;
  std::mutex sync_mutex_;                   // one pass at a time
  std::unique_ptr<records::RecordsDb> db_;  // null while the database is unreachable
  std::set<std::string> recorded_;          // run ids known to be in the database

  mutable std::mutex mutex_;  // guards the fields below
  std::condition_variable wake_cv_;
  bool woken_ = false;
  bool stopping_ = false;
  RecordsSyncReport report_;
  std::thread thread_;
};

}  // namespace standcal::daemon
