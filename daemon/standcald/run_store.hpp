#pragma once
// The state directory (docs/daemon.md):
//   STATE/runs/RUN_ID/run.json        what the run is and how far it got (atomic rewrite)
//   STATE/runs/RUN_ID/recording.csv   the recording, appended and fsync'ed per position
//   STATE/runs/RUN_ID/result.json     the calibration, once the run is done
//   STATE/units/SERIAL.json           the index of runs per unit serial
// run.json is rewritten only AFTER the recording holds a position durably, and records
// the recording's length at that point: on resume the file is cut back to that length,
// so a position half-written by a crash is measured again, never kept twice.
#include <cstdint>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/traceability.hpp"
#include "daemon/standcald/pid_lock.hpp"
#include "protocol/jsonrpc/messages.hpp"

namespace standcal::daemon {

// A run as standcald keeps it (run.json): its traceability, the programme and the run's
// progress.
struct RunRecord : Traceability {
  nlohmann::json program;  // the normalised programme (calib's programme JSON)
  double dwell_s = 60;
  double settle_s = 5;
  std::string state;   // protocol::run_state
  std::string reason;  // why faulted / aborted / interrupted
  int positions = 0;
  int positions_done = 0;                         // positions durably in the recording
  std::uint64_t recording_bytes = 0;              // recording length covering positions_done
  std::uint64_t header_bytes = 0;                 // length of the header block alone
  std::vector<std::uint64_t> position_end_bytes;  // recording length after each done position
  double last_t_s = 0;  // last t_s written (the run clock resumes after it)
  std::string recording_path;
  std::string result_path;  // empty until the fit is stored
};

// What runs.list, the unit index and resume need of a run: kept in memory for every run
// in the state directory (about 0.3 kB each), while the full record (the programme, the
// per-position byte offsets, a few kB) stays on disk and is read when asked for.
// It is what runs.list answers with, so it is the protocol's type.
using RunSummary = protocol::RunListEntry;

RunSummary summary_of(const RunRecord& r);

// Which runs one runs.list page holds: newest first, only `unit_serial`'s when not empty,
// only those older than `before_run_id` (run ids sort by start time) when not empty, at
// most `limit`. Paging keeps an answer's size (and the memory it takes to build and send)
// bounded however many runs the state directory holds.
struct RunPageQuery {
  std::string unit_serial;
  std::string before_run_id;
  std::size_t limit = SIZE_MAX;
};
struct RunPage {
  std::vector<RunSummary> runs;
  bool more = false;  // older runs match the query beyond this page
};

nlohmann::json to_json(const RunRecord& r);
RunRecord run_record_from_json(const nlohmann::json& j);

// STATE/units/ file name of a serial's index: every byte outside [A-Za-z0-9._-] (and '%'
// and a leading '.') percent-encoded, so two serials never share a file ("a/b", "a_b",
// "AU,1" and "AU\t1" used to) and a plain serial keeps its old name ("AU-0042.json").
std::string unit_index_file_name(const std::string& unit_serial);

// Writes a file of the state directory whole or not at all, mode 0640
// (calib/atomic_file.hpp: temporary file, fsync, rename, fsync of the directory).
void write_state_file(const std::string& path, const std::string& text);

// One standcald per state directory: an exclusive flock on STATE/standcald.lock, held
// until the process ends (the kernel drops it even after SIGKILL, so a crash leaves no
// stale lock). A second daemon on the same directory would mark the first one's active run
// `interrupted` and serve the same runs.
class StateDirLock {
 public:
  // Creates the directory if needed; throws naming the directory and, when the lock file
  // says, the pid of the daemon holding it.
  explicit StateDirLock(const std::string& state_dir);

 private:
  PidLock lock_;
};

// Thread-safe: the sequencer writes, the server's readers read.
// Memory per run is its RunSummary only; full records are read from run.json on demand,
// except the run saved last (the one the sequencer is working on, asked for on every
// run.status) and any run whose last save could not reach the disk (memory keeps the
// truth until a later save of that run succeeds).
class RunStore {
 public:
  // Opens (creating) the state directory and loads every run; runs a crash left
  // running, paused or waiting for the operator become `interrupted`.
  explicit RunStore(std::string state_dir);

  // A new id ("20261121T221500Z-AU-0042"), unique in this store.
  std::string new_run_id(const std::string& unit_serial);
  std::string run_dir(const std::string& run_id) const;
  // Stores (creates or replaces) a run's record and updates its unit's index. Memory is
  // updated first, so when the write throws (disk full) get() still tells the truth.
  void save(const RunRecord& r);
  // The full record: from memory for the run saved last, else read from its run.json.
  // Nothing when there is no such run or its run.json can no longer be read.
  std::optional<RunRecord> get(const std::string& run_id) const;
  // One page of runs, newest first (RunPageQuery; the default query is every run).
  RunPage page(const RunPageQuery& q) const;
  std::optional<RunSummary> newest() const;
  // The newest run that can be resumed (interrupted, faulted or paused).
  std::optional<RunRecord> latest_resumable() const;
  const std::string& state_dir() const { return state_dir_; }

 private:
  struct HeldRecord {
    RunRecord record;
    bool on_disk = false;  // false: the last write failed, memory is the only truth
  };
  void write_unit_index(const std::string& unit_serial) const;
  std::optional<RunRecord> get_locked(const std::string& run_id) const;

  std::string state_dir_;
  mutable std::mutex mutex_;
  std::vector<RunSummary> runs_;  // every run, in run_id order
  std::vector<HeldRecord> held_;  // the run saved last, and runs not on disk
};

// Appends rows to a recording and makes them durable (write, fflush, fsync).
class RecordingFile {
 public:
  // Creates `path` with the header block.
  static RecordingFile create(const std::string& path, const std::string& header);
  // Opens `path` for appending after cutting it to `length` bytes.
  static RecordingFile reopen(const std::string& path, std::uint64_t length);
  RecordingFile(RecordingFile&& other) noexcept;
  RecordingFile& operator=(RecordingFile&&) = delete;
  RecordingFile(const RecordingFile&) = delete;
  ~RecordingFile();
  // Appends and fsyncs; returns the file length afterwards. Throws with the path and errno.
  std::uint64_t append_durably(const std::string& text);
  // Appends without fsync (a position written as its samples come: a warm-up of hours is not
  // held whole); sync() then makes it durable. Both return the file length afterwards.
  std::uint64_t append(const std::string& text);
  std::uint64_t sync();
  // Cuts the file back to `length` bytes and syncs: what a position left unfinished (a fault or
  // a pause in it) had written. Throws with the path and errno.
  void cut_back(std::uint64_t length);
  std::uint64_t length() const { return length_; }

 private:
  RecordingFile(std::string path, int fd, std::uint64_t length);
  std::string path_;
  int fd_ = -1;
  std::uint64_t length_ = 0;
};

// Power loss on a disk whose cache drops fsync'ed writes, or a recording copied back
// short, can leave the recording shorter than `r.recording_bytes`. This keeps every
// position still whole in the file (by `position_end_bytes`), sets positions_done and
// recording_bytes to them (0 bytes: the header is gone too, start the file again) and
// returns what was dropped for the operator; empty when the file is as long as recorded.
std::string fit_record_to_recording(RunRecord& r);

}  // namespace standcal::daemon
