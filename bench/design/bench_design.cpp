// Prints how long `design optimize` takes for N = 9 and N = 24 (target < 5 s each) and a
// full-vector fit of a simulated 24-position recording (target < 0.2 s: read + average + fit),
// and the dwell plan `design compare` prints (allocated dwells and the continuous-design limit).
#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "calib/averaging.hpp"
#include "calib/design.hpp"
#include "calib/full_estimator.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

void time_optimize(int positions) {
  standcal::OptimizeOptions options;
  options.positions = positions;
  const auto t0 = Clock::now();
  const auto best = standcal::optimize_program(options);
  const double s = seconds_since(t0);
  std::printf(
      "optimize N=%-2d (invariant, %d restarts): %.3f s  [target < 5 s]  det^(1/9) %.4f (paper9 "
      "%.4f)\n",
      positions, options.restarts, s, best.d_criterion, best.paper9_d_criterion);
}

void time_full_fit() {
  standcal::SimulationRequest req;
  req.program = standcal::classic24();
  req.truth = standcal::default_truth();
  req.timing.dwell_s = 10;
  const auto path = (std::filesystem::temp_directory_path() /
                     ("bench_design_" + std::to_string(::getpid()) + ".csv"))
                        .string();
  standcal::write_recording(standcal::simulate_run(req), path);
  constexpr int kRepeats = 5;
  double fit_only = 0, whole = 0;
  std::size_t samples = 0;
  for (int r = 0; r < kRepeats; ++r) {
    const auto t0 = Clock::now();
    const standcal::Recording rec = standcal::read_recording(path);
    const auto averages = standcal::average_positions(rec);
    const auto t1 = Clock::now();
    const standcal::FitResult fit = standcal::fit_full_vector(averages);
    fit_only += seconds_since(t1) / kRepeats;
    whole += seconds_since(t0) / kRepeats;
    samples = rec.samples.size();
    if (fit.positions != 24) std::printf("unexpected: %d positions fitted\n", fit.positions);
  }
  std::filesystem::remove(path);
  std::printf(
      "full-vector fit of a 24-position recording (%zu samples): fit %.4f s, read+average+fit %.4f "
      "s  "
      "[target < 0.2 s]\n",
      samples, fit_only, whole);
}

void time_dwell_plan() {
  const standcal::DesignSettings settings;
  const standcal::AccuracyTarget target;
  const auto t0 = Clock::now();
  const auto basis = standcal::design_basis(standcal::poses_of(standcal::paper9()),
                                            standcal::DesignModel::invariant);
  const auto plan = standcal::allocated_dwell_for_target(basis, target, settings);
  const double allocated_s = seconds_since(t0);
  const auto t1 = Clock::now();
  const double limit_s =
      standcal::continuous_lower_bound_s(standcal::DesignModel::invariant, target, settings);
  const double limit_time_s = seconds_since(t1);
  std::printf(
      "dwell plan for paper9: allocated %.0f s of dwell in %.3f s; continuous-design limit %.0f s "
      "in %.3f s\n",
      plan.total_dwell_s, allocated_s, limit_s, limit_time_s);
}

}  // namespace

int main() {
  time_optimize(9);
  time_optimize(24);
  time_full_fit();
  time_dwell_plan();
  return 0;
}
