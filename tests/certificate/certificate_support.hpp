#pragma once
// A finished calibration run laid out as standcald leaves it (docs/daemon.md), made with
// the project's simulator: STATE/runs/RUN_ID/{run.json,recording.csv}.
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::test {

inline Recording simulated_recording(const std::string& serial, const TruthModel& truth,
                                     std::uint64_t seed, const std::string& program = "paper9",
                                     double dwell_s = 10) {
  SimulationRequest req;
  req.program = load_program(program);
  req.truth = truth;
  req.seed = seed;
  req.timing.dwell_s = dwell_s;
  req.unit_serial = serial;
  Recording rec = simulate_run(req);
  rec.set_header("program", req.program.name);
  return rec;
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out.flush()) throw std::runtime_error("cannot write " + path.string());
}

// Writes STATE/runs/RUN_ID as the daemon does once a run is done.
inline std::filesystem::path write_done_run(const std::filesystem::path& state_dir,
                                            const std::string& run_id, Recording rec,
                                            const std::string& state = "done") {
  const std::filesystem::path dir = state_dir / "runs" / run_id;
  std::filesystem::create_directories(dir);
  rec.set_header("run_id", run_id);
  rec.set_header("stand_id", "stand-B2");
  write_recording(rec, (dir / "recording.csv").string());
  const nlohmann::json run{{"run_id", run_id},
                           {"unit_serial", rec.unit_serial},
                           {"program_name", rec.program},
                           {"operator", "I. Petrova"},
                           {"state", state},
                           {"positions", 9},
                           {"positions_done", 9},
                           {"started_utc", "2026-11-21T22:36:38Z"},
                           {"ended_utc", "2026-11-21T22:58:02Z"},
                           {"recording_path", (dir / "recording.csv").string()},
                           {"stand_id", "stand-B2"},
                           {"config_hash", "sha256:5f2c9a"},
                           {"software_version", "0.1.0"},
                           {"g_source", "gravimetric survey 2024, pillar 3"},
                           {"g_local_mps2", rec.g_local_mps2}};
  write_text(dir / "run.json", run.dump(2) + "\n");
  return dir;
}

}  // namespace standcal::test
