#pragma once
// The fault-injection rig shared by tests/faults and bench/faults: a real standcald on
// its real backends, the Modbus stand driver talking to standcal-stand-emu (a libmodbus
// server, TCP on loopback or RTU through a socat pty pair) and the SocketCAN unit reading
// standcal-can-emu's frames through a SOCK_SEQPACKET socketpair (this kernel has no CAN;
// the unit backend takes an inherited fd as `unit.interface: "fd:N"`).
//
// Both emulators take fault lines from a control file while they run, so a fault starts
// at a chosen point of a run. After a fault the rig checks the four promises of issue 7:
//   1. the stand ends stopped        — the emulator's own axis registers (status file)
//   2. the run's state is truthful   — run.status / run.json
//   3. every position recorded before the fault is intact — byte-for-byte, per position
//   4. resume completes the run      — run.resume → done, every position exactly once
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "protocol/jsonrpc/client.hpp"

namespace standcal::faults {

using nlohmann::json;
using namespace std::chrono_literals;

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::ofstream(tmp, std::ios::trunc) << text;
  std::filesystem::rename(tmp, path);
}

struct ChildSetup {
  std::vector<int> close_fds;   // fds of the parent this child must not keep
  bool ignore_sigxfsz = false;  // a size-limited file then gives EFBIG, as a full disk gives ENOSPC
};

// A child process, killed (SIGKILL) when this goes out of scope.
class Child {
 public:
  Child(std::vector<std::string> argv, const std::string& out_path, const std::string& err_path,
        ChildSetup setup = ChildSetup{}) {
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive a crashed test
      for (int fd : setup.close_fds) ::close(fd);
      if (setup.ignore_sigxfsz) ::signal(SIGXFSZ, SIG_IGN);
      const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(out, 1);
      ::dup2(err, 2);
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
  }
  ~Child() { kill_and_wait(SIGKILL); }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }
  bool exited() {
    if (pid_ <= 0) return true;
    if (::waitpid(pid_, &status_, WNOHANG) == pid_) {
      pid_ = -1;
      return true;
    }
    return false;
  }
  // Sends `sig` and waits (SIGKILL after 20 s).
  void kill_and_wait(int sig) {
    if (pid_ <= 0) return;
    ::kill(pid_, sig);
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (!exited()) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status_, 0);
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(5ms);
    }
  }

 private:
  pid_t pid_ = -1;
  int status_ = 0;
};

// One axis as the emulated controller's input registers show it.
struct AxisRegisters {
  int state = -1;  // 0 disabled, 1 idle, 2 homing, 3 moving, 4 in position, 5 fault
  int flags = 0;
  long angle_counts = 0;
  int fault = 0;
  bool stopped() const { return state != 2 && state != 3 && state >= 0; }
};

// The positions of a recording text, each position's rows as they stand in the file.
inline std::map<int, std::string> position_blocks(const std::string& text) {
  std::map<int, std::string> blocks;
  std::istringstream in(text);
  std::string line;
  int pos_column = -1;
  while (std::getline(in, line)) {
    if (in.eof()) break;  // a last line without its newline is not a whole row
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream cs(line);
    for (std::string cell; std::getline(cs, cell, ',');) cells.push_back(cell);
    if (pos_column < 0) {
      for (std::size_t i = 0; i < cells.size(); ++i)
        if (cells[i] == "pos") pos_column = static_cast<int>(i);
      continue;
    }
    if (static_cast<std::size_t>(pos_column) >= cells.size()) continue;
    blocks[std::stoi(cells[static_cast<std::size_t>(pos_column)])] += line + "\n";
  }
  return blocks;
}

// How many of the position blocks of `before` are missing or changed in `after`.
inline int positions_lost(const std::map<int, std::string>& before,
                          const std::map<int, std::string>& after) {
  int lost = 0;
  for (const auto& [pos, rows] : before) {
    auto it = after.find(pos);
    if (it == after.end() || it->second != rows) ++lost;
  }
  return lost;
}

// Whether each position 0..n-1 appears in the recording as one block, in order, once.
inline bool every_position_once(const std::string& text, int n, std::string& why) {
  std::istringstream in(text);
  std::string line;
  int pos_column = -1, current = -1;
  std::vector<bool> seen(static_cast<std::size_t>(n), false);
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream cs(line);
    for (std::string cell; std::getline(cs, cell, ',');) cells.push_back(cell);
    if (pos_column < 0) {
      for (std::size_t i = 0; i < cells.size(); ++i)
        if (cells[i] == "pos") pos_column = static_cast<int>(i);
      continue;
    }
    const int pos = std::stoi(cells.at(static_cast<std::size_t>(pos_column)));
    if (pos == current) continue;
    if (pos < 0 || pos >= n || seen[static_cast<std::size_t>(pos)]) {
      why = "position " + std::to_string(pos + 1) + " appears twice or out of range";
      return false;
    }
    if (pos != current + 1) {
      why = "position " + std::to_string(pos + 1) + " follows position " +
            std::to_string(current + 1);
      return false;
    }
    seen[static_cast<std::size_t>(pos)] = true;
    current = pos;
  }
  if (current != n - 1) {
    why = "the recording ends after position " + std::to_string(current + 1) + " of " +
          std::to_string(n);
    return false;
  }
  return true;
}

struct RigOptions {
  std::string daemon_path;
  std::string stand_emu_path;
  std::string can_emu_path;
  bool rtu = false;  // the stand over RTU through a socat pty pair
  double can_rate_hz = 200;
  double dwell_s = 0.3;
  double settle_s = 0.05;
  std::string program = "paper9";
  std::string work_dir;  // empty: a fresh temporary directory, removed at the end
};

class Rig {
 public:
  explicit Rig(RigOptions o) : o_(std::move(o)) {
    if (o_.work_dir.empty()) {
      std::string tmpl =
          (std::filesystem::temp_directory_path() / "standcal-faults-XXXXXX").string();
      if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
      dir_ = tmpl;
      own_dir_ = true;
    } else {
      dir_ = o_.work_dir;
      std::filesystem::create_directories(dir_);
    }
    write_text(stand_control(), "");
    write_text(can_control(), "");
    start_stand();
    write_config();
  }
  ~Rig() {
    daemon_.reset();
    can_emu_.reset();
    stand_emu_.reset();
    socat_.reset();
    if (own_dir_) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
  }
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  const std::string& dir() const { return dir_; }
  std::string socket_path() const { return dir_ + "/standcald.sock"; }
  std::string state_dir() const { return dir_ + "/state"; }
  std::string stand_control() const { return dir_ + "/stand.faults"; }
  std::string can_control() const { return dir_ + "/can.faults"; }
  pid_t daemon_pid() const { return daemon_ ? daemon_->pid() : -1; }

  void set_stand_faults(const std::string& lines) { write_text(stand_control(), lines); }
  void set_can_faults(const std::string& lines) { write_text(can_control(), lines); }

  // A fresh CAN unit emulator and a standcald on it; waits until the socket answers.
  void start_daemon(bool ignore_sigxfsz = false) {
    daemon_.reset();
    can_emu_.reset();
    int pair[2];
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, pair) != 0)
      throw std::runtime_error("socketpair failed");
    can_emu_ = std::make_unique<Child>(
        std::vector<std::string>{o_.can_emu_path, "--fd", std::to_string(pair[0]), "--rate-hz",
                                 std::to_string(o_.can_rate_hz), "--control", can_control(),
                                 "--seed", std::to_string(++starts_)},
        dir_ + "/can-emu.log", dir_ + "/can-emu.log", ChildSetup{{pair[1]}, false});
    json config = config_;
    config["unit"]["interface"] = "fd:" + std::to_string(pair[1]);
    write_text(dir_ + "/standcald.json", config.dump(2));
    daemon_ = std::make_unique<Child>(
        std::vector<std::string>{o_.daemon_path, "--config", dir_ + "/standcald.json"},
        dir_ + "/standcald.log", dir_ + "/standcald.log", ChildSetup{{pair[0]}, ignore_sigxfsz});
    ::close(pair[0]);
    ::close(pair[1]);
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline) {
      try {
        client_ = std::make_unique<protocol::Client>(socket_path(), 10s);
        return;
      } catch (const std::exception&) {
      }
      if (daemon_->exited()) throw std::runtime_error("standcald exited at start:\n" + log());
      std::this_thread::sleep_for(20ms);
    }
    throw std::runtime_error("standcald did not answer within 30 s:\n" + log());
  }

  void kill_daemon(int sig = SIGKILL) {
    client_.reset();
    if (daemon_) daemon_->kill_and_wait(sig);
    daemon_.reset();
    can_emu_.reset();
  }

  json call(const std::string& method, const json& params = json::object()) {
    return client_->call(method, params, 30s);
  }

  std::string start_run() {
    return call("run.start", {{"program", o_.program}, {"unit_serial", "AU-FAULT"}})["run_id"];
  }

  // Polls run.status until `done(status)` or the timeout; returns the last status.
  json wait_status(const std::string& run_id, const std::function<bool(const json&)>& done,
                   std::chrono::seconds timeout) {
    json s;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      s = call("run.status", {{"run_id", run_id}});
      if (done(s)) return s;
      std::this_thread::sleep_for(20ms);
    }
    return s;
  }
  json wait_not_running(const std::string& run_id, std::chrono::seconds timeout = 60s) {
    return wait_status(
        run_id, [](const json& s) { return s["state"] != "running"; }, timeout);
  }
  json wait_positions(const std::string& run_id, int n, std::chrono::seconds timeout = 60s) {
    return wait_status(
        run_id,
        [n](const json& s) {
          return s["state"] != "running" || s["positions_done"].get<int>() >= n;
        },
        timeout);
  }

  json run_json(const std::string& run_id) const {
    return json::parse(read_text(state_dir() + "/runs/" + run_id + "/run.json"));
  }
  std::string recording_path(const std::string& run_id) const {
    return state_dir() + "/runs/" + run_id + "/recording.csv";
  }
  // The recording up to the length run.json says is durable.
  std::string durable_recording(const std::string& run_id) const {
    const std::string text = read_text(recording_path(run_id));
    const auto bytes = run_json(run_id).value("recording_bytes", std::uint64_t{0});
    return text.substr(0, std::min<std::size_t>(text.size(), bytes));
  }

  std::vector<AxisRegisters> stand_registers() const {
    std::istringstream in(read_text(dir_ + "/stand-status"));
    std::vector<AxisRegisters> axes;
    std::string name;
    AxisRegisters a;
    while (in >> name >> a.state >> a.flags >> a.angle_counts >> a.fault) axes.push_back(a);
    return axes;
  }
  // Whether both axes are stopped (not moving, not homing), waiting up to `timeout` for
  // a controlled stop to finish; `why` says what an axis was doing otherwise.
  bool stand_stopped(std::string& why, std::chrono::milliseconds timeout = 3000ms) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto axes = stand_registers();
      bool stopped = axes.size() == 2;
      for (const auto& a : axes) stopped = stopped && a.stopped();
      if (stopped) {
        // Stopped means staying still: two readings 200 ms apart agree (encoder noise aside).
        std::this_thread::sleep_for(200ms);
        const auto later = stand_registers();
        bool still = later.size() == 2;
        for (std::size_t i = 0; still && i < 2; ++i)
          still =
              later[i].stopped() && std::labs(later[i].angle_counts - axes[i].angle_counts) <= 5;
        if (still) return true;
      }
      if (std::chrono::steady_clock::now() > deadline) {
        why = "stand axes not stopped: " + read_text(dir_ + "/stand-status");
        return false;
      }
      std::this_thread::sleep_for(50ms);
    }
  }

  std::string log() const { return read_text(dir_ + "/standcald.log"); }

 private:
  void start_stand() {
    std::string listen = "tcp://127.0.0.1:0";
    std::string drive_url;
    if (o_.rtu) {
      socat_ = std::make_unique<Child>(
          std::vector<std::string>{"/usr/bin/socat", "pty,raw,echo=0,link=" + dir_ + "/emu-tty",
                                   "pty,raw,echo=0,link=" + dir_ + "/drv-tty"},
          dir_ + "/socat.log", dir_ + "/socat.log");
      const auto deadline = std::chrono::steady_clock::now() + 10s;
      while (!(std::filesystem::exists(dir_ + "/emu-tty") &&
               std::filesystem::exists(dir_ + "/drv-tty"))) {
        if (std::chrono::steady_clock::now() > deadline)
          throw std::runtime_error("socat made no pty pair");
        std::this_thread::sleep_for(20ms);
      }
      listen = "rtu:" + dir_ + "/emu-tty?baud=115200&parity=N&unit=1";
      drive_url = "rtu:" + dir_ + "/drv-tty?baud=115200&parity=N&unit=1";
    }
    stand_emu_ = std::make_unique<Child>(
        std::vector<std::string>{o_.stand_emu_path, "--listen", listen, "--time-scale", "25",
                                 "--control", stand_control(), "--status-file",
                                 dir_ + "/stand-status"},
        dir_ + "/stand-emu.out", dir_ + "/stand-emu.log");
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    for (;;) {
      std::istringstream out(read_text(dir_ + "/stand-emu.out"));
      std::string line;
      if (std::getline(out, line) && !out.eof() && !line.empty() &&
          std::filesystem::exists(dir_ + "/stand-status")) {
        stand_url_ = o_.rtu ? drive_url : line;
        return;
      }
      if (std::chrono::steady_clock::now() > deadline || stand_emu_->exited())
        throw std::runtime_error("standcal-stand-emu did not start: " +
                                 read_text(dir_ + "/stand-emu.log"));
      std::this_thread::sleep_for(20ms);
    }
  }

  void write_config() {
    // Timeouts so a fault shows within a few seconds; the stand emulator runs
    // 25x faster than real time, the unit at 200 Hz.
    const json map{
        {"timing",
         {{"timeout_s", 1.0},  // generous: a busy 2-core CI machine must not time out by itself
          {"tries", 3},
          {"backoff_first_s", 0.05},
          {"backoff_max_s", 0.4},
          {"heartbeat_period_s", 0.1},
          // Past 0.1 + 3 x 1.0 s: a request the driver is still retrying never lets the
          // watchdog stop the stand (drivers/modbus heartbeat_margin_warning).
          {"heartbeat_timeout_s", 3.5}}}};
    write_text(dir_ + "/stand-map.json", map.dump(2));
    config_ = json{{"socket", {{"path", socket_path()}}},
                   {"state_dir", state_dir()},
                   {"stand",
                    {{"backend", "modbus"},
                     {"url", stand_url_},
                     {"id", "emu-stand"},
                     {"register_map", dir_ + "/stand-map.json"},
                     {"in_position", {{"window_deg", 0.002}, {"dwell_s", 0.05}, {"timeout_s", 3}}},
                     {"home_timeout_s", 30}}},
                   {"unit", {{"backend", "socketcan"}, {"sample_rate_hz", o_.can_rate_hz}}},
                   {"run",
                    {{"settle_s", o_.settle_s},
                     {"dwell_s", o_.dwell_s},
                     {"stability", {{"min_sample_fraction", 0.8}, {"remeasure_max", 1}}}}}};
  }

  RigOptions o_;
  std::string dir_;
  bool own_dir_ = false;
  std::string stand_url_;
  json config_;
  int starts_ = 0;
  std::unique_ptr<Child> socat_, stand_emu_, can_emu_, daemon_;
  std::unique_ptr<protocol::Client> client_;
};

}  // namespace standcal::faults
