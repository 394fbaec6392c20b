// The offline commands against the cost of reading their file (issue 17), each as a user
// runs it (its own process), with its peak memory:
//   - `standcal fit --json` of a one-hour, 100 Hz recording (classic24, 24 x 150 s =
//     360 000 rows, 40 MB), beside `wc -l` of the same file (the floor: reading the bytes
//     once), `standcal --version` (process start-up) and, when python3-numpy is installed
//     (scripts/perf.sh installs it), a numpy reference pipeline (bench/fit/numpy_fit.py);
//   - `standcal diagnose --json` of the same file;
//   - `standcal noise --json` of a static recording of 3 million rows (one position,
//     30 000 s at 100 Hz, 330 MB).
// And, inside one process, the streamed read + reduction and the fit alone.
// Targets (issue 17): fit <= 50 ms and <= 20 MiB, <= 3x wc -l, >= 30x numpy; diagnose
// <= 0.25 s and <= 40 MiB; noise <= 1 s and <= 100 MB.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/support/command.hpp"
#include "bench/support/timing.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/recording_digest.hpp"
#include "calib/simulator.hpp"
#include "protocol/jsonrpc/exit_codes.hpp"

using namespace standcal;
using standcal::bench::Clock;
using standcal::bench::CommandFigures;
using standcal::bench::measure_command;
using standcal::bench::median;
using standcal::bench::seconds_of;

namespace {

constexpr int kRepeats = 7;

std::string write_simulated(const SimulationRequest& req, const std::string& name) {
  const Recording rec = simulate_run(req);
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  write_recording(rec, path);
  std::printf("recording: %s, %zu rows, %.1f MB -> %s\n", rec.program.c_str(), rec.samples.size(),
              static_cast<double>(std::filesystem::file_size(path)) / 1e6, path.c_str());
  return path;
}

std::string one_hour_recording() {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 150;  // 24 x 150 s x 100 Hz = 360 000 rows
  return write_simulated(req, "standcal_bench_1h.csv");
}

std::string three_million_rows() {
  SimulationRequest req;
  req.program.name = "static";
  req.program.positions = {ProgramPosition{}};
  req.timing.dwell_s = 30000;  // x 100 Hz
  return write_simulated(req, "standcal_bench_3m_rows.csv");
}

void print_row(const char* what, const CommandFigures& f, const char* target) {
  std::printf("  %-34s %8.1f ms %8.1f MiB   %s\n", what, f.median_s * 1e3, f.peak_rss_mib, target);
}

void in_process(const std::string& path) {
  std::vector<double> digest_s, fit_s;
  for (int i = 0; i < kRepeats; ++i) {
    const auto t0 = Clock::now();
    const RecordingDigest d = digest_recording(path);
    digest_s.push_back(seconds_of(t0));
    const auto t1 = Clock::now();
    const FitResult fit = fit_invariant_joint(d.averages);
    fit_s.push_back(seconds_of(t1));
    if (fit.positions != 24) std::exit(1);
  }
  std::printf("in one process, one thread (median of %d):\n", kRepeats);
  std::printf("  read + average + Allan (streamed)  %8.1f ms\n", median(digest_s) * 1e3);
  std::printf("  fit_invariant_joint                %8.2f ms\n", median(fit_s) * 1e3);
}

// Debian's interpreter, the one python3-numpy installs for (a PATH python3 may be another).
constexpr const char* kPython = "/usr/bin/python3";

bool numpy_installed() {
  return std::system("/usr/bin/python3 -c 'import numpy' 2>/dev/null") == 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Line-buffered even into a pipe, so the figures measured before a failure are kept.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const bool with_noise = !(argc > 1 && std::string(argv[1]) == "--no-noise");
  const std::string cli = STANDCAL_CLI;
  const std::string path = one_hour_recording();
  in_process(path);

  std::printf("as a user runs them (median of %d, largest peak RSS):\n", kRepeats);
  const CommandFigures wc = measure_command({"wc", "-l", path}, kRepeats);
  print_row("wc -l (the floor)", wc, "");
  print_row("standcal --version (start-up)", measure_command({cli, "--version"}, kRepeats), "");
  const CommandFigures fit = measure_command({cli, "fit", path, "--json"}, kRepeats);
  print_row("standcal fit --json", fit, "target <= 50 ms, <= 20 MiB");
  std::printf(
      "    = %.1fx wc -l (goal <= 3x); threads: 2 (the file in two parts, each parsed, averaged "
      "and Allan-pooled on its own)\n",
      fit.median_s / wc.median_s);
  if (numpy_installed()) {
    const CommandFigures numpy = measure_command({kPython, STANDCAL_NUMPY_FIT, path}, 3);
    print_row("numpy reference pipeline", numpy, "");
    std::printf("    standcal fit is %.1fx faster (goal >= 30x)\n", numpy.median_s / fit.median_s);
  } else {
    std::printf(
        "  numpy reference pipeline: python3-numpy is not installed (scripts/perf.sh installs "
        "it)\n");
  }
  print_row("standcal diagnose --json",
            measure_command({cli, "diagnose", path, "--json"}, 3, is_diagnosis_answer),
            "target <= 250 ms, <= 40 MiB; threads: 1");
  std::filesystem::remove(path);

  if (with_noise) {
    const std::string static_path = three_million_rows();
    print_row("standcal noise --json (3 M rows)",
              measure_command({cli, "noise", static_path, "--json"}, 3),
              "target <= 1000 ms, <= 100 MB; threads: 2 (parse | Allan: one dwell, one part)");
    std::filesystem::remove(static_path);
  }
  return 0;
}
