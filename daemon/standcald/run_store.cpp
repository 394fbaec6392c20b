#include "daemon/standcald/run_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "calib/atomic_file.hpp"
#include "calib/json_text.hpp"
#include "daemon/standcald/errno_text.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "protocol/jsonrpc/run_id.hpp"

namespace standcal::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

void write_all(int fd, const std::string& text, const std::string& path) {
  if (!write_fully(fd, text))
    throw std::runtime_error("cannot write " + path + ": " + errno_text());
}

const std::string& id_of(const RunSummary& r) { return r.run_id; }
const std::string& id_of(const std::string& id) { return id; }

// Run ids from unit serials: keep what is safe, replace the rest (an id need not be
// reversible: a clash gets a -002 suffix). One character of the name per character (UTF-8
// code point) of `s`, so a 64-character serial gives at most 64 here however many bytes it
// has (a file name has 255 at most).
std::string safe_name(const std::string& s) {
  std::string out;
  for (char ch : s) {
    if ((static_cast<unsigned char>(ch) & 0xC0) == 0x80) continue;  // inside a multi-byte character
    out += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_' || ch == '.')
               ? ch
               : '_';
  }
  if (out.empty() || out[0] == '.') out = "_" + out;
  return out;
}

// FNV-1a, 64 bits: a stable name for a serial too long to spell out in a file name.
std::uint64_t fnv1a_64(const std::string& s) {
  std::uint64_t h = 14695981039346656037ull;
  for (const char ch : s) {
    h ^= static_cast<unsigned char>(ch);
    h *= 1099511628211ull;
  }
  return h;
}

// A file name has at most 255 bytes; ".json.tmp" and room to spare leave 200 for the stem.
constexpr std::size_t kMaxIndexStemBytes = 200;

// Past that (a 64-character serial of 4-byte characters is 768 bytes encoded), the stem is
// the encoding's start (whole %XX triples only) and '~' with the hash of the whole serial:
// no longer reversible, still one file per serial, and the file itself names its serial.
std::string shortened_stem(const std::string& encoded, const std::string& unit_serial) {
  std::size_t keep = kMaxIndexStemBytes - 17;
  while (keep > 0 && (encoded[keep - 1] == '%' || (keep > 1 && encoded[keep - 2] == '%'))) --keep;
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx",
                static_cast<unsigned long long>(fnv1a_64(unit_serial)));
  return encoded.substr(0, keep) + "~" + hash;
}

}  // namespace

std::string unit_index_file_name(const std::string& unit_serial) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (std::size_t i = 0; i < unit_serial.size(); ++i) {
    const auto byte = static_cast<unsigned char>(unit_serial[i]);
    const bool plain = std::isalnum(byte) || byte == '-' || byte == '_' || (byte == '.' && i > 0);
    if (plain) {
      out += static_cast<char>(byte);
    } else {  // also '%' itself, and a leading '.' (no hidden file, no "." or "..")
      out += '%';
      out += kHex[byte >> 4];
      out += kHex[byte & 0xF];
    }
  }
  if (out.size() > kMaxIndexStemBytes) out = shortened_stem(out, unit_serial);
  return out + ".json";
}

void write_state_file(const std::string& path, const std::string& text) {
  write_file_atomically(path, text, "the run state", 0640);
}

namespace {

// STATE/standcald.lock, creating the directory on a first start.
std::string state_lock_path(const std::string& state_dir) {
  std::error_code ignored;  // a failure shows when the lock file is opened
  fs::create_directories(state_dir, ignored);
  return (fs::path(state_dir) / "standcald.lock").string();
}

}  // namespace

StateDirLock::StateDirLock(const std::string& state_dir)
    : lock_(state_lock_path(state_dir), [&state_dir](const std::string& holder) {
        return "the state directory " + state_dir + " is in use by another standcald" +
               (holder.empty() ? std::string() : " (pid " + holder + ")") + ", which holds " +
               state_dir +
               "/standcald.lock; stop it first, or give this daemon its own state directory";
      }) {}

json to_json(const RunRecord& r) {
  return json{{"run_id", r.run_id},
              {"unit_serial", r.unit_serial},
              {"unit_type", r.unit_type},
              {"program_name", r.program_name},
              {"program", r.program},
              {"dwell_s", r.dwell_s},
              {"settle_s", r.settle_s},
              {"operator", r.operator_name},
              {"state", r.state},
              {"reason", r.reason},
              {"positions", r.positions},
              {"positions_done", r.positions_done},
              {"recording_bytes", r.recording_bytes},
              {"header_bytes", r.header_bytes},
              {"position_end_bytes", r.position_end_bytes},
              {"last_t_s", r.last_t_s},
              {"started_utc", r.started_utc},
              {"ended_utc", r.ended_utc},
              {"recording_path", r.recording_path},
              {"result_path", r.result_path},
              {"stand_id", r.stand_id},
              {"config_hash", r.config_hash},
              {"software_version", r.software_version},
              {"g_source", r.g_source},
              {"g_local_mps2", r.g_local_mps2}};
}

RunSummary summary_of(const RunRecord& r) {
  return RunSummary{r.run_id,      r.unit_serial, r.program_name,
                    r.state,       r.positions,   r.positions_done,
                    r.started_utc, r.ended_utc,   !r.result_path.empty()};
}

RunRecord run_record_from_json(const json& j) {
  RunRecord r;
  r.run_id = j.at("run_id").get<std::string>();
  r.unit_serial = j.value("unit_serial", "");
  r.unit_type = j.value("unit_type", "");
  r.program_name = j.value("program_name", "");
  r.program = j.value("program", json::object());
  r.dwell_s = j.value("dwell_s", 60.0);
  r.settle_s = j.value("settle_s", 5.0);
  r.operator_name = j.value("operator", "");
  r.state = j.value("state", "");
  r.reason = j.value("reason", "");
  r.positions = j.value("positions", 0);
  r.positions_done = j.value("positions_done", 0);
  r.recording_bytes = j.value("recording_bytes", std::uint64_t{0});
  r.header_bytes = j.value("header_bytes", std::uint64_t{0});
  r.position_end_bytes = j.value("position_end_bytes", std::vector<std::uint64_t>{});
  r.last_t_s = j.value("last_t_s", 0.0);
  r.started_utc = j.value("started_utc", "");
  r.ended_utc = j.value("ended_utc", "");
  r.recording_path = j.value("recording_path", "");
  r.result_path = j.value("result_path", "");
  r.stand_id = j.value("stand_id", "");
  r.config_hash = j.value("config_hash", "");
  r.software_version = j.value("software_version", "");
  r.g_source = j.value("g_source", "");
  r.g_local_mps2 = j.value("g_local_mps2", 0.0);
  return r;
}

RunStore::RunStore(std::string state_dir) : state_dir_(std::move(state_dir)) {
  std::error_code ec;
  fs::create_directories(fs::path(state_dir_) / "runs", ec);
  fs::create_directories(fs::path(state_dir_) / "units", ec);
  if (!fs::is_directory(fs::path(state_dir_) / "runs")) {
    throw std::runtime_error("cannot create the state directory " + state_dir_ + ": " +
                             ec.message());
  }
  namespace st = protocol::run_state;
  for (const auto& entry : fs::directory_iterator(fs::path(state_dir_) / "runs")) {
    const fs::path file = entry.path() / "run.json";
    std::ifstream in(file);
    if (!in) continue;
    json j = json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.contains("run_id")) continue;  // never written completely: ignore
    RunRecord r = run_record_from_json(j);
    if (r.state == st::running || r.state == st::paused || r.state == st::waiting_operator) {
      r.state = st::interrupted;
      r.reason =
          "standcald stopped during the run (crash, kill or power loss); run.resume continues it";
      write_state_file(run_dir(r.run_id) + "/run.json", json_text(to_json(r)) + "\n");
    }
    runs_.push_back(summary_of(r));
  }
  std::sort(runs_.begin(), runs_.end(),
            [](const RunSummary& a, const RunSummary& b) { return a.run_id < b.run_id; });
}

std::string RunStore::new_run_id(const std::string& unit_serial) {
  std::lock_guard lock(mutex_);
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm);
  const std::string base = std::string(stamp) + "-" + safe_name(unit_serial);
  std::string id = base;
  // A second run of this unit within the same UTC second gets "-002", "-003", …: zero
  // padded, so ids keep sorting in the order the runs started (runs.list pages by id).
  for (int n = 2; fs::exists(fs::path(state_dir_) / "runs" / id); ++n) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "-%03d", n);
    id = base + suffix;
  }
  fs::create_directories(fs::path(state_dir_) / "runs" / id);
  return id;
}

std::string RunStore::run_dir(const std::string& run_id) const {
  return (fs::path(state_dir_) / "runs" / run_id).string();
}

void RunStore::save(const RunRecord& r) {
  std::lock_guard lock(mutex_);
  // Memory first: when the disk is full the file write throws, but run.status must still
  // tell the truth about the run (the file keeps the last state that could be written,
  // which a restart turns into `interrupted`).
  auto it = std::find_if(runs_.begin(), runs_.end(),
                         [&](const RunSummary& x) { return x.run_id == r.run_id; });
  const bool is_new = it == runs_.end();
  if (is_new) {
    // Kept in run_id order (ids start with their UTC second), the order a restart
    // loads them in, so newest-first means the same before and after a restart.
    auto pos =
        std::upper_bound(runs_.begin(), runs_.end(), r.run_id,
                         [](const std::string& id, const RunSummary& x) { return id < x.run_id; });
    runs_.insert(pos, summary_of(r));
  } else {
    *it = summary_of(r);
  }
  // Held in full: this run, and runs whose newest state only memory has.
  std::erase_if(held_,
                [&](const HeldRecord& h) { return h.on_disk || h.record.run_id == r.run_id; });
  held_.push_back(HeldRecord{r, false});
  write_state_file(run_dir(r.run_id) + "/run.json", json_text(to_json(r)) + "\n");
  held_.back().on_disk = true;
  if (is_new) write_unit_index(r.unit_serial);
}

void RunStore::write_unit_index(const std::string& unit_serial) const {
  json ids = json::array();
  for (const RunSummary& r : runs_) {
    if (r.unit_serial == unit_serial) ids.push_back(r.run_id);
  }
  const std::string path =
      (fs::path(state_dir_) / "units" / unit_index_file_name(unit_serial)).string();
  write_state_file(path, json_text(json{{"unit_serial", unit_serial}, {"runs", ids}}) + "\n");
}

std::optional<RunRecord> RunStore::get(const std::string& run_id) const {
  std::lock_guard lock(mutex_);
  return get_locked(run_id);
}

std::optional<RunRecord> RunStore::get_locked(const std::string& run_id) const {
  for (const HeldRecord& h : held_) {
    if (h.record.run_id == run_id) return h.record;
  }
  // Only ids of run id form that this store knows: a request's run_id must not name an
  // arbitrary path.
  if (!protocol::is_run_id(run_id)) return std::nullopt;
  const bool known =
      std::binary_search(runs_.begin(), runs_.end(), run_id,
                         [](const auto& a, const auto& b) { return id_of(a) < id_of(b); });
  if (!known) return std::nullopt;
  std::ifstream in(run_dir(run_id) + "/run.json");
  const json j = json::parse(in, nullptr, false);
  if (!in || j.is_discarded() || !j.contains("run_id")) return std::nullopt;
  return run_record_from_json(j);
}

RunPage RunStore::page(const RunPageQuery& q) const {
  std::lock_guard lock(mutex_);
  auto end = runs_.end();
  if (!q.before_run_id.empty()) {
    end =
        std::lower_bound(runs_.begin(), runs_.end(), q.before_run_id,
                         [](const RunSummary& r, const std::string& id) { return r.run_id < id; });
  }
  RunPage out;
  for (auto it = std::make_reverse_iterator(end); it != runs_.rend(); ++it) {
    if (!q.unit_serial.empty() && it->unit_serial != q.unit_serial) continue;
    if (out.runs.size() == q.limit) {
      out.more = true;
      break;
    }
    out.runs.push_back(*it);
  }
  return out;
}

std::optional<RunSummary> RunStore::newest() const {
  std::lock_guard lock(mutex_);
  if (runs_.empty()) return std::nullopt;
  return runs_.back();
}

std::optional<RunRecord> RunStore::latest_resumable() const {
  namespace st = protocol::run_state;
  std::lock_guard lock(mutex_);
  for (auto it = runs_.rbegin(); it != runs_.rend(); ++it) {
    if (it->state == st::interrupted || it->state == st::faulted || it->state == st::paused) {
      return get_locked(it->run_id);
    }
  }
  return std::nullopt;
}

std::string fit_record_to_recording(RunRecord& r) {
  struct stat st {};
  const std::uint64_t size =
      ::stat(r.recording_path.c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  if (size >= r.recording_bytes) return {};
  const int had = r.positions_done;
  int kept = std::min<int>(had, static_cast<int>(r.position_end_bytes.size()));
  while (kept > 0 && r.position_end_bytes[static_cast<std::size_t>(kept - 1)] > size) --kept;
  r.position_end_bytes.resize(static_cast<std::size_t>(kept));
  r.positions_done = kept;
  if (kept > 0) {
    r.recording_bytes = r.position_end_bytes.back();
  } else if (r.header_bytes > 0 && r.header_bytes <= size) {
    r.recording_bytes = r.header_bytes;
  } else {
    r.recording_bytes = 0;  // even the header is gone: the recording starts again
    r.header_bytes = 0;
  }
  std::string note = "the recording " + r.recording_path + " was cut short (" +
                     std::to_string(size) + " bytes; power loss or a lost disk cache?): ";
  if (kept == had) {
    note += "no whole position lost";
  } else if (kept + 1 == had) {
    note += "position " + std::to_string(had) + " is measured again";
  } else {
    note += "positions " + std::to_string(kept + 1) + " to " + std::to_string(had) +
            " are measured again";
  }
  return note;
}

RecordingFile::RecordingFile(std::string path, int fd, std::uint64_t length)
    : path_(std::move(path)), fd_(fd), length_(length) {}

RecordingFile::RecordingFile(RecordingFile&& o) noexcept
    : path_(std::move(o.path_)), fd_(o.fd_), length_(o.length_) {
  o.fd_ = -1;
}

RecordingFile::~RecordingFile() {
  if (fd_ >= 0) ::close(fd_);
}

RecordingFile RecordingFile::create(const std::string& path, const std::string& header) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_APPEND | O_CLOEXEC, 0640);
  if (fd < 0) throw std::runtime_error("cannot create the recording " + path + ": " + errno_text());
  RecordingFile f(path, fd, 0);
  f.append_durably(header);
  fsync_directory(fs::path(path).parent_path().string());
  return f;
}

RecordingFile RecordingFile::reopen(const std::string& path, std::uint64_t length) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open the recording " + path + ": " + errno_text());
  struct stat st {};
  if (::fstat(fd, &st) != 0 || static_cast<std::uint64_t>(st.st_size) < length) {
    ::close(fd);
    throw std::runtime_error("the recording " + path + " is shorter than its run record says (" +
                             std::to_string(length) + " bytes): it was changed or lost");
  }
  RecordingFile f(path, fd, length);
  f.cut_back(length);  // whatever a crash left after the last durable position
  return f;
}

std::uint64_t RecordingFile::append_durably(const std::string& text) {
  append(text);
  return sync();
}

std::uint64_t RecordingFile::append(const std::string& text) {
  write_all(fd_, text, path_);
  length_ += text.size();
  return length_;
}

std::uint64_t RecordingFile::sync() {
  if (::fsync(fd_) != 0)
    throw std::runtime_error("cannot fsync the recording " + path_ + ": " + errno_text());
  return length_;
}

void RecordingFile::cut_back(std::uint64_t length) {
  if (::ftruncate(fd_, static_cast<off_t>(length)) != 0 || ::fsync(fd_) != 0)
    throw std::runtime_error("cannot cut back the recording " + path_ + ": " + errno_text());
  length_ = length;
}

}  // namespace standcal::daemon
