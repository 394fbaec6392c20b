// Speed of the model-mismatch diagnosis (issue 6 target: a 1-hour, 100 Hz recording with
// the full catalog in under 10 s on this machine). The recording is diagnostic32 with
// 112 s dwells (32 x 112 s x 100 Hz = 358 400 samples, just over an hour with moves and
// settling) and a bias drift to find, written to CSV; the bench times reading it and the
// diagnosis itself, step by step, and prints the medians.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/support/timing.hpp"
#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/simulator.hpp"

using namespace standcal;
using standcal::bench::Clock;
using standcal::bench::median;
using standcal::bench::seconds_of;

namespace {

std::string one_hour_recording() {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.truth.temperature.rate_c_per_h = 10;
  req.truth.temperature.cycle_amplitude_c = 2;
  req.truth.temperature.cycle_period_s = 600;
  req.truth.extra_physics.push_back({"bias_drift", "z", 20, 0, 0});
  req.timing.dwell_s = 112;
  req.timing.settle_s = 2;
  const Recording rec = simulate_run(req);
  const std::string path =
      (std::filesystem::temp_directory_path() / "standcal_bench_diagnose_1h.csv").string();
  write_recording(rec, path);
  std::printf("recording: diagnostic32, %zu samples over %.0f s at 100 Hz, %.1f MB -> %s\n",
              rec.samples.size(), rec.samples.back().t_s,
              static_cast<double>(std::filesystem::file_size(path)) / 1e6, path.c_str());
  return path;
}

}  // namespace

int main() {
  const std::string path = one_hour_recording();
  constexpr int kRepeats = 3;
  std::vector<double> read_s, diagnose_s, total_s;
  Diagnosis last;
  for (int i = 0; i < kRepeats; ++i) {
    const auto t0 = Clock::now();
    const Recording rec = read_recording(path);
    read_s.push_back(seconds_of(t0));
    const auto t1 = Clock::now();
    last = diagnose_recording(rec);
    diagnose_s.push_back(seconds_of(t1));
    total_s.push_back(seconds_of(t0));
  }
  std::size_t tested = 0;
  for (const auto& c : last.candidates) tested += c.testable ? 1 : 0;
  std::printf("verdict %s, %zu findings (first: %s %s), %zu candidate tests (%zu testable)\n",
              last.verdict.c_str(), last.findings.size(),
              last.findings.empty() ? "-" : last.findings.front().effect.c_str(),
              last.findings.empty() ? "" : last.findings.front().axis.c_str(),
              last.candidates.size(), tested);
  std::printf("median of %d runs:\n", kRepeats);
  std::printf("  read (CSV parse)         %7.3f s\n", median(read_s));
  std::printf("  diagnose_recording       %7.3f s\n", median(diagnose_s));
  std::printf("  read + diagnose          %7.3f s  (target < 10 s)\n", median(total_s));
  std::filesystem::remove(path);
  return 0;
}
