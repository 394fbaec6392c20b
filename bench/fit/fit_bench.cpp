// Speed of the offline fit on one hour of 100 Hz data (360 000 samples): read + average
// + fit inside one process, and the whole `standcal fit` command as a user runs it.
// Prints its figures; the target (issue 2) is the whole command in under 1 s.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/support/timing.hpp"
#include "calib/averaging.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/simulator.hpp"

using namespace standcal;
using standcal::bench::Clock;
using standcal::bench::median;
using standcal::bench::seconds_of;

namespace {

std::string one_hour_recording() {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 150;  // 24 x 150 s x 100 Hz = 360 000 samples
  const Recording rec = simulate_run(req);
  const std::string path = (std::filesystem::temp_directory_path() / "standcal_bench_1h.csv").string();
  write_recording(rec, path);
  std::printf("recording: %zu samples, %.1f MB -> %s\n", rec.samples.size(),
              static_cast<double>(std::filesystem::file_size(path)) / 1e6, path.c_str());
  return path;
}

}  // namespace

int main() {
  const std::string path = one_hour_recording();
  constexpr int kRepeats = 5;
  std::vector<double> read_s, average_s, fit_s, total_s, cli_s;
  std::size_t samples = 0;
  for (int i = 0; i < kRepeats; ++i) {
    const auto t0 = Clock::now();
    const Recording rec = read_recording(path);
    read_s.push_back(seconds_of(t0));
    const auto t1 = Clock::now();
    const auto averages = average_positions(rec);
    average_s.push_back(seconds_of(t1));
    const auto t2 = Clock::now();
    const FitResult fit = fit_invariant_joint(averages);
    fit_s.push_back(seconds_of(t2));
    total_s.push_back(seconds_of(t0));
    samples = rec.samples.size();
    if (fit.positions != 24) return 1;
  }
  const std::string command = std::string(STANDCAL_CLI) + " fit " + path + " --json > /dev/null";
  for (int i = 0; i < kRepeats; ++i) {
    const auto t0 = Clock::now();
    if (std::system(command.c_str()) != 0) return 1;
    cli_s.push_back(seconds_of(t0));
  }
  std::printf("median of %d runs:\n", kRepeats);
  std::printf("  read (CSV parse)      %8.3f s\n", median(read_s));
  std::printf("  average positions     %8.3f s\n", median(average_s));
  std::printf("  fit (joint WLS)       %8.5f s\n", median(fit_s));
  std::printf("  read+average+fit      %8.3f s  = %.2f M samples/s\n", median(total_s),
              static_cast<double>(samples) / median(total_s) / 1e6);
  std::printf("  `standcal fit --json` %8.3f s  (target < 1 s)\n", median(cli_s));
  std::filesystem::remove(path);
  return 0;
}
