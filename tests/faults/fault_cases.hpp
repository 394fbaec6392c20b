#pragma once
// The faults of issue 7 as trials on the rig (fault_rig.hpp), shared by the `faults`
// tests (one trial each, a few seeds of the kill/power-loss cases) and bench/faults (many
// seeded tries, the table in docs/reliability.md). A trial starts a paper9 run, injects
// the fault at a (seeded) point, checks the four promises and resumes the run.
#include <sys/resource.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>

#include "tests/faults/fault_rig.hpp"

namespace standcal::faults {

struct FaultCase {
  std::string name;
  std::string what;  // one line for the table
  bool rtu = false;
  // The run's state right after the fault: "faulted", "interrupted" (the daemon died and
  // was restarted) or "done" (the fault was absorbed: retries, duplicates ignored).
  std::string expect;
  std::vector<std::string> reason_has;  // one of these in the run's reason ("faulted" only)
  bool ignore_sigxfsz = false;
  // Starts the fault (the run is in progress, `done_at_start` positions recorded).
  // May return the positions that must survive when the fault itself destroys data
  // (power loss); otherwise the durable recording after the fault is the reference.
  std::function<std::optional<std::map<int, std::string>>(Rig&, const std::string& run_id,
                                                          std::mt19937& rng)>
      inject;
  std::function<void(Rig&)> clear;          // the operator fixed the cause
  int inject_after_positions = 2;           // < 0: seeded in 0..8
  std::function<void(Rig&)> before_resume;  // what else the operator fixes after checking the stand
};

struct Trial {
  bool survived = false;
  int positions_lost = 0;
  std::string state_after_fault;
  std::string reason;
  std::string failure;  // which promise broke, empty when survived
};

namespace detail {

inline std::string reason_of(const json& s) { return s.value("reason", std::string{}); }

// t_s never decreases (the run clock continues after a resume; samples read in one
// batch from a socketpair share a timestamp, so equal values are allowed), and no sample
// is in a position twice: with the unit's noise two samples never carry the same three
// forces, so an equal (fx, fy, fz) triple in one position is a duplicated sample.
inline bool times_ordered(const std::string& text, std::string& why) {
  std::istringstream in(text);
  std::string line;
  int t_col = -1, pos_col = -1, f_col = -1, last_pos = -1;
  double last_t = -1e300;
  std::set<std::string> forces;  // of the current position
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream cs(line);
    for (std::string cell; std::getline(cs, cell, ',');) cells.push_back(cell);
    if (t_col < 0) {
      for (std::size_t i = 0; i < cells.size(); ++i) {
        if (cells[i] == "t_s") t_col = static_cast<int>(i);
        if (cells[i] == "pos") pos_col = static_cast<int>(i);
        if (cells[i] == "fx_mps2") f_col = static_cast<int>(i);
      }
      if (t_col < 0 || pos_col < 0 || f_col < 0) {
        why = "no t_s/pos/fx_mps2 column";
        return false;
      }
      continue;
    }
    const double t = std::stod(cells.at(static_cast<std::size_t>(t_col)));
    const int pos = std::stoi(cells.at(static_cast<std::size_t>(pos_col)));
    if (t < last_t) {
      why = "t_s goes back at position " + std::to_string(pos + 1) + ": " + line.substr(0, 40);
      return false;
    }
    if (pos != last_pos) forces.clear();
    const auto f = static_cast<std::size_t>(f_col);
    if (!forces.insert(cells.at(f) + "," + cells.at(f + 1) + "," + cells.at(f + 2)).second) {
      why = "a sample is twice in position " + std::to_string(pos + 1) + ": " + line.substr(0, 60);
      return false;
    }
    last_t = t;
    last_pos = pos;
  }
  return true;
}

}  // namespace detail

// One trial of `c` with `seed`; never throws for a broken promise (it is reported).
inline Trial run_trial(RigOptions options, const FaultCase& c, unsigned seed) {
  Trial out;
  std::mt19937 rng(seed);
  options.rtu = c.rtu;
  try {
    Rig rig(options);
    rig.start_daemon(c.ignore_sigxfsz);
    const std::string run_id = rig.start_run();
    const int after = c.inject_after_positions >= 0 ? c.inject_after_positions
                                                    : std::uniform_int_distribution<int>(0, 8)(rng);
    json s = rig.wait_positions(run_id, after);
    if (s["state"] != "running") {
      out.failure = "the run stopped before the fault: " + s.dump();
      return out;
    }
    auto must_survive = c.inject(rig, run_id, rng);
    const bool restarted = c.expect == "interrupted";
    if (restarted) {
      // The daemon is gone: the controller's watchdog must stop the stand by itself.
      std::string why;
      if (!rig.stand_stopped(why, 8000ms)) {  // the watchdog acts after heartbeat_timeout_s (3.5 s)
        out.failure = "with standcald killed: " + why;
        return out;
      }
      rig.start_daemon();
      s = rig.call("run.status", {{"run_id", run_id}});
    } else {
      s = rig.wait_not_running(run_id, 60s);
    }
    out.state_after_fault = s["state"];
    out.reason = detail::reason_of(s);
    if (s["state"] != c.expect) {
      out.failure = "state " + s["state"].get<std::string>() + ", expected " + c.expect + " (" +
                    out.reason + ")";
      return out;
    }
    if (c.expect == "faulted" && !c.reason_has.empty()) {
      bool named = false;
      for (const auto& word : c.reason_has)
        named = named || out.reason.find(word) != std::string::npos;
      if (!named) {
        out.failure = "the reason does not name the fault: " + out.reason;
        return out;
      }
    }
    // Whether on disk the run is as truthful as run.status (a restart would read it).
    const json disk = rig.run_json(run_id);
    if (disk["state"] != c.expect) {
      out.failure =
          "run.json says " + disk["state"].get<std::string>() + ", run.status " + c.expect;
      return out;
    }
    // A daemon that lived through the fault leaves whole positions only: the one it was in is
    // cut back off the file (a disk_full append had left half of it there).
    if (!restarted) {
      const auto on_disk = std::filesystem::file_size(rig.recording_path(run_id));
      const auto durable = disk["recording_bytes"].get<std::uint64_t>();
      if (on_disk != durable) {
        out.failure = "the recording is " + std::to_string(on_disk) + " bytes after the fault, " +
                      std::to_string(durable) + " in run.json: a position left part-written";
        return out;
      }
    }
    if (c.clear) c.clear(rig);
    if (std::string why; !rig.stand_stopped(why)) {
      out.failure = "after the fault: " + why;
      return out;
    }
    const auto before =
        must_survive ? *must_survive : position_blocks(rig.durable_recording(run_id));
    if (c.before_resume) c.before_resume(rig);
    if (c.expect != "done") {
      rig.call("run.resume", {{"run_id", run_id}});  // answers once the run is running again
      s = rig.wait_not_running(run_id, 90s);
      if (s["state"] != "done") {
        out.failure = "resume ended " + s["state"].get<std::string>() + ": " + detail::reason_of(s);
        return out;
      }
    }
    const std::string final_text = read_text(rig.recording_path(run_id));
    out.positions_lost = positions_lost(before, position_blocks(final_text));
    std::string why;
    if (!every_position_once(final_text, 9, why) || !detail::times_ordered(final_text, why)) {
      out.failure = "final recording: " + why;
      return out;
    }
    if (out.positions_lost != 0) {
      out.failure = std::to_string(out.positions_lost) + " recorded position(s) lost or changed";
      return out;
    }
    if (std::string w; !rig.stand_stopped(w)) {
      out.failure = "after the run: " + w;
      return out;
    }
    out.survived = true;
  } catch (const std::exception& e) {
    out.failure = std::string("exception: ") + e.what();
  }
  return out;
}

namespace inject {

using Injected = std::optional<std::map<int, std::string>>;

inline auto stand(std::string lines) {
  return [lines](Rig& rig, const std::string&, std::mt19937&) -> Injected {
    rig.set_stand_faults(lines);
    return std::nullopt;
  };
}
inline auto can(std::string lines) {
  return [lines](Rig& rig, const std::string&, std::mt19937&) -> Injected {
    rig.set_can_faults(lines);
    return std::nullopt;
  };
}
// During a dwell, so the unit is being sampled when the fault hits.
inline auto can_while_sampling(std::string lines) {
  return [lines](Rig& rig, const std::string& run_id, std::mt19937&) -> Injected {
    rig.wait_status(
        run_id, [](const json& s) { return s["state"] != "running" || s["phase"] == "sampling"; },
        30s);
    rig.set_can_faults(lines);
    return std::nullopt;
  };
}

// The recording may grow by about one more position, then the disk is "full".
inline Injected disk_full(Rig& rig, const std::string& run_id, std::mt19937&) {
  const json r = rig.run_json(run_id);
  const auto bytes = r["recording_bytes"].get<std::uint64_t>();
  const auto header = r.value("header_bytes", std::uint64_t{0});
  const int done = std::max(1, r["positions_done"].get<int>());
  const std::uint64_t per_position = (bytes - header) / static_cast<std::uint64_t>(done);
  // Only the soft limit: raising it again ("the disk was freed") needs no privilege.
  rlimit lim{static_cast<rlim_t>(bytes + per_position * 3 / 2), RLIM_INFINITY};
  if (::prlimit(rig.daemon_pid(), RLIMIT_FSIZE, &lim, nullptr) != 0)
    throw std::runtime_error("prlimit failed");
  return std::nullopt;
}
inline void disk_freed(Rig& rig) {
  rlimit lim{RLIM_INFINITY, RLIM_INFINITY};
  if (::prlimit(rig.daemon_pid(), RLIMIT_FSIZE, &lim, nullptr) != 0)
    throw std::runtime_error("prlimit failed");
}

// SIGKILL after a seeded 0..0.8 s more (the run was `inject_after_positions` in).
inline Injected sigkill(Rig& rig, const std::string&, std::mt19937& rng) {
  std::this_thread::sleep_for(
      std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 800)(rng)));
  rig.kill_daemon(SIGKILL);
  return std::nullopt;
}

// SIGKILL, then the recording cut at a seeded byte anywhere in it — harsher than a real
// power loss, which only loses what was not yet fsync'ed. The positions that must
// survive are those still whole in the cut file that run.json counted as done.
inline Injected power_loss(Rig& rig, const std::string& run_id, std::mt19937& rng) {
  sigkill(rig, run_id, rng);
  const std::string path = rig.recording_path(run_id);
  const std::string text = read_text(path);
  const auto cut = std::uniform_int_distribution<std::size_t>(0, text.size())(rng);
  std::filesystem::resize_file(path, cut);
  const json r = rig.run_json(run_id);
  const auto ends = r.value("position_end_bytes", std::vector<std::uint64_t>{});
  const int done = r["positions_done"].get<int>();
  std::uint64_t intact = 0;
  for (int p = 0; p < done && p < static_cast<int>(ends.size()); ++p)
    if (ends[static_cast<std::size_t>(p)] <= cut) intact = ends[static_cast<std::size_t>(p)];
  return position_blocks(text.substr(0, static_cast<std::size_t>(intact)));
}

}  // namespace inject

// The link times out while both axes crawl through a long move: once the link is back
// the driver's heartbeat keeps the controller's watchdog quiet, so only an explicit stop
// from the daemon ends that move.
inline inject::Injected timeout_mid_move(Rig& rig, const std::string& run_id, std::mt19937&) {
  rig.set_stand_faults("slow outer 1000\nslow inner 1000");
  rig.wait_status(
      run_id, [](const json& s) { return s["state"] != "running" || s["phase"] == "moving"; }, 30s);
  std::this_thread::sleep_for(300ms);
  rig.set_stand_faults("slow outer 1000\nslow inner 1000\ndelay_ms 3000");
  return std::nullopt;
}

inline void clear_all(Rig& rig) {
  rig.set_stand_faults("");
  rig.set_can_faults("");
  std::this_thread::sleep_for(150ms);  // both emulators re-read within 50 ms
}

// Every fault of issue 7.
inline std::vector<FaultCase> all_cases() {
  std::vector<FaultCase> v;
  v.push_back({"modbus_timeout",
               "stand replies 3 s late (driver timeout 1 s x 3 tries)",
               false,
               "faulted",
               {"no reply", "lost the link"},
               false,
               inject::stand("delay_ms 3000"),
               clear_all,
               2,
               {}});
  {
    FaultCase c{"modbus_timeout_mid_move",
                "replies 3 s late while both axes crawl through a move",
                false,
                "faulted",
                {"no reply", "lost the link"},
                false,
                timeout_mid_move,
                [](Rig& rig) {
                  rig.set_stand_faults(
                      "slow outer 1000\nslow inner 1000");  // the link is back, the axes still slow
                  std::this_thread::sleep_for(150ms);
                },
                1,
                clear_all};
    v.push_back(c);
  }
  v.push_back({"modbus_exception",
               "every stand request answered with exception 4",
               false,
               "faulted",
               {"exception"},
               false,
               inject::stand("exception 4"),
               clear_all,
               2,
               {}});
  v.push_back({"tcp_drop_once",
               "the stand closes the TCP connection once",
               false,
               "done",
               {},
               false,
               inject::stand("drop 1"),
               clear_all,
               2,
               {}});
  v.push_back({"tcp_drop_persistent",
               "the stand closes every TCP connection",
               false,
               "faulted",
               {"no reply", "lost the link", "connect"},
               false,
               inject::stand("drop 1000000"),
               clear_all,
               2,
               {}});
  v.push_back({"rtu_crc_once",
               "RTU: two replies with a bad CRC (socat pty pair)",
               true,
               "done",
               {},
               false,
               inject::stand("corrupt 2"),
               clear_all,
               2,
               {}});
  v.push_back({"rtu_crc_persistent",
               "RTU: every reply with a bad CRC",
               true,
               "faulted",
               {"CRC", "no reply", "lost the link"},
               false,
               inject::stand("corrupt 1000000"),
               clear_all,
               2,
               {}});
  v.push_back({"stuck_axis",
               "outer axis does not follow (following error)",
               false,
               "faulted",
               {"faulted", "did not reach"},
               false,
               inject::stand("stuck outer"),
               clear_all,
               2,
               {}});
  v.push_back({"slow_axis",
               "both axes 200x slower than their limits",
               false,
               "faulted",
               {"did not reach"},
               false,
               inject::stand("slow outer 200\nslow inner 200"),
               clear_all,
               2,
               {}});
  v.push_back({"overshoot",
               "drives settle 0.05 deg past the target yet report in position",
               false,
               "faulted",
               {"did not reach"},
               false,
               inject::stand("overshoot outer 0.05\novershoot inner 0.05"),
               clear_all,
               2,
               {}});
  v.push_back({"can_silence",
               "the unit sends nothing",
               false,
               "faulted",
               {"no CAN frame", "no sample"},
               false,
               inject::can_while_sampling("silence"),
               clear_all,
               2,
               {}});
  v.push_back({"can_bus_off",
               "bus-off during a dwell, controller restarts after 1.5 s",
               false,
               "faulted",
               {"bus-off", "no CAN frame", "no sample"},
               false,
               inject::can_while_sampling("bus_off 1500"),
               [](Rig& rig) {
                 clear_all(rig);
                 std::this_thread::sleep_for(1500ms);  // the operator resumes once the bus is back
               },
               2,
               {}});
  v.push_back({"can_missing_frames",
               "half of all CAN frames lost",
               false,
               "faulted",
               {"expected samples"},
               false,
               inject::can("loss 0.5"),
               clear_all,
               2,
               {}});
  v.push_back({"can_duplicate_frames",
               "30 % of CAN frames sent twice",
               false,
               "done",
               {},
               false,
               inject::can("duplicate 0.3"),
               clear_all,
               2,
               {}});
  v.push_back({"disk_full",
               "recording file size limit (RLIMIT_FSIZE) reached mid-run",
               false,
               "faulted",
               {"File too large", "No space"},
               true,
               inject::disk_full,
               inject::disk_freed,
               2,
               {}});
  v.push_back({"sigkill",
               "SIGKILL of standcald at a seeded point of the run",
               false,
               "interrupted",
               {},
               false,
               inject::sigkill,
               {},
               -1,
               {}});
  v.push_back({"power_loss",
               "SIGKILL + recording cut at a seeded byte",
               false,
               "interrupted",
               {},
               false,
               inject::power_loss,
               {},
               -1,
               {}});
  return v;
}

inline FaultCase find_case(const std::string& name) {
  for (auto& c : all_cases())
    if (c.name == name) return c;
  throw std::runtime_error("no fault case " + name);
}

}  // namespace standcal::faults
