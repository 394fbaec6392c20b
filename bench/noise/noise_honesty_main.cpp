// standcal-bench-noise-honesty: issue 21's Monte Carlo. Prints, per scenario (white noise,
// Gauss-Markov bias wander at 1x, 3x, 10x the white error of one dwell mean) and per
// estimator, the z-variance (mean of ((estimate - truth) / sigma)^2) of each unit parameter:
// 1 is an honest sigma. "estimated" weights as `standcal fit` does (the run's own noise
// model); "tau given" as `standcal fit --bias-instability-tau-s T`; "unit given" as that
// with `--bias-instability-ug Q` too (the unit's wander known before the run), or with
// --static-hours H as `--unit-static-recording` of an H-hour static recording; "true" with
// the simulated wander whatever the run shows; "white" as if every dwell mean were
// independent, for comparison. Under each table,
// each weighting's sigmas over the white-weighted sigmas of the same fit on the same run
// (median, 99th percentile, share above 3x): what weighting for a wander the run may not
// have costs a single run under white noise, and how far it widens under wander.
//   standcal-bench-noise-honesty [--runs 1000] [--threads 2] [--program diagnostic32]
//                                [--repeat 1] [--tau-s 300 [--tau-max-s 1200]]
//                                [--tau-given-range 1 | --tau-given-factor 1]
//                                [--size-given-factor 1 | --static-hours H]
//                                [--specified-exceeded-p 0.05]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "bench/noise/noise_mc.hpp"
#include "calib/design.hpp"
#include "calib/diagnosis/diagnosis.hpp"

using namespace standcal;
using namespace standcal::noise_mc;

namespace {

// The q-quantile (0..1) of `values` (reordered).
double quantile(std::vector<double>& values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

// Each weighting's sigmas against the white-weighted ones of the same estimator on the same
// run: the median, the 99th percentile and how many exceed three times.
void print_sigma_over_white(const ScenarioResult& r) {
  std::printf(
      "  sigma / the same fit's sigma weighted as white noise, same run: median, 99th "
      "percentile, share above 3x\n");
  std::printf("  %-6s %-10s %-24s %-24s %-24s\n", "fit", "weighting", "biases", "scale factors",
              "gammas");
  for (const ZStats& z : r.stats) {
    if (z.weighting == "white" || z.runs == 0) continue;
    std::printf("  %-6s %-10s", z.estimator.c_str(), z.weighting.c_str());
    for (std::vector<double> ratios : z.sigma_over_white) {
      if (ratios.empty()) {
        std::printf(" %-24s", "-");
        continue;
      }
      const auto above =
          std::count_if(ratios.begin(), ratios.end(), [](double x) { return x > 3; });
      const double share = static_cast<double>(above) / static_cast<double>(ratios.size());
      char cell[64];
      std::snprintf(cell, sizeof cell, "%5.2f %6.2f %5.1f%%", quantile(ratios, 0.5),
                    quantile(ratios, 0.99), 100 * share);
      std::printf(" %-24s", cell);
    }
    std::printf("\n");
  }
}

std::string tau_words(const Scenario& s) {
  char b[96];
  if (s.tau_drawn())
    std::snprintf(b, sizeof b, "tau drawn log-uniformly from %.0f-%.0f s each run", s.tau_s,
                  s.tau_max_s);
  else
    std::snprintf(b, sizeof b, "tau %.0f s", s.tau_s);
  return b;
}

// The biases' z-variance over the runs each fit weighted as white noise and over those it
// weighted for a wander: an estimated noise model's excess lies where it took none.
void print_bias_z2_by_weighting(const ScenarioResult& r) {
  std::printf(
      "  biases' z-variance by the fit's weighting: runs, range; the wander's q^2 weighted "
      "with over the simulated one's, mean over runs and axes\n");
  std::printf("  %-6s %-10s %-22s %-22s %s\n", "fit", "weighting", "weighted as white",
              "weighted for a wander", "q^2 / truth");
  for (const ZStats& z : r.stats) {
    if (z.weighting == "white" || z.weighting == "true" || z.runs == 0) continue;
    std::printf("  %-6s %-10s", z.estimator.c_str(), z.weighting.c_str());
    for (std::size_t w = 0; w < 2; ++w) {
      const int n = z.runs_by_weighting[w];
      const auto& sums = z.bias_z2_by_weighting[w];
      char cell[64] = "-";
      if (n > 0)
        std::snprintf(cell, sizeof cell, "%5d %6.2f-%.2f", n,
                      *std::min_element(sums.begin(), sums.end()) / n,
                      *std::max_element(sums.begin(), sums.end()) / n);
      std::printf(" %-22s", cell);
    }
    if (z.wander_q2_ratio_n > 0) std::printf(" %5.3f", z.wander_q2_ratio_sum / z.wander_q2_ratio_n);
    std::printf("\n");
  }
}

void print_result(const ScenarioResult& r) {
  std::printf(
      "\n%s (wander %.1f ug, %s; white error of one dwell mean %.2f ug; samples taken as "
      "correlated within the dwells in %d runs)\n",
      r.scenario.name.c_str(), r.scenario.wander_per_dwell_error * r.white_dwell_error_ug,
      tau_words(r.scenario).c_str(), r.white_dwell_error_ug, r.samples_correlated);
  std::printf("  %-6s %-10s %5s %5s  z-variance per parameter", "fit", "weighting", "runs",
              "wand.");
  std::printf("\n  %-6s %-10s %5s %5s ", "", "", "", "");
  for (const auto& name : kUnitParameterNames) std::printf(" %8.8s", std::string(name).c_str());
  std::printf("   range      min cover\n");
  for (const ZStats& z : r.stats) {
    std::printf("  %-6s %-10s %5d %5d ", z.estimator.c_str(), z.weighting.c_str(), z.runs,
                z.wander_significant);
    if (z.runs == 0) {  // e.g. the norm fit, refused classic24's six orientations
      std::printf("  every one of the %d fits failed\n", z.failed);
      continue;
    }
    double lo = 1e300, hi = 0;
    for (std::size_t j = 0; j < z.z2_mean.size(); ++j) {
      if (z.n[j] == 0) {
        std::printf(" %8s", "-");
        continue;
      }
      std::printf(" %8.2f", z.z2_mean[j]);
      lo = std::min(lo, z.z2_mean[j]);
      hi = std::max(hi, z.z2_mean[j]);
    }
    double worst_coverage = 1;
    for (std::size_t j = 0; j < z.n.size(); ++j)
      if (z.n[j] > 0) worst_coverage = std::min(worst_coverage, z.coverage95[j]);
    std::printf("   %.2f-%.2f  %4.1f%%", lo, hi, 100 * worst_coverage);
    if (z.failed) std::printf(" (%d fits failed)", z.failed);
    if (z.recording_wander > 0)
      std::printf(" (the long dwell's wander taken in %d)", z.recording_wander);
    if (z.recording_tau_floor > 0)
      std::printf(" (the floor its curves put under tau taken in %d)", z.recording_tau_floor);
    if (z.weighting == "unit given" && z.unit_given < z.runs)
      std::printf(" (given a wander in %d: the static recording's)", z.unit_given);
    std::printf("\n");
  }
  print_sigma_over_white(r);
  print_bias_z2_by_weighting(r);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Monte Carlo of the estimators' sigmas under white and coloured noise (issue 21)"};
  Setup setup;
  std::string program = "diagnostic32";
  double tau_s = 300;
  double tau_max_s = 0;
  int repeat = 1;
  app.add_option("--runs", setup.runs, "simulated runs per scenario")->capture_default_str();
  app.add_option("--threads", setup.threads, "worker threads")->capture_default_str();
  app.add_option("--seed", setup.first_seed, "seed of the first run")->capture_default_str();
  app.add_option("--program", program, "diagnostic32, paper9, classic24 or a programme JSON file")
      ->capture_default_str();
  app.add_option("--repeat", repeat,
                 "visit the programme's positions this many times in a row (a longer run: does "
                 "it pin the wander's correlation time?)")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  app.add_option("--dwell-s", setup.dwell_s)->capture_default_str();
  app.add_option("--rate-hz", setup.sample_rate_hz)->capture_default_str();
  app.add_option("--tau-s", tau_s, "correlation time of the wander")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--tau-max-s", tau_max_s,
                 "each run draws its wander's correlation time log-uniformly from --tau-s to "
                 "this: are the sigmas honest over units whose tau nobody measured?")
      ->check(CLI::PositiveNumber);
  app.add_option("--tau-given-factor", setup.tau_given_factor,
                 "the 'tau given' rows weight with this multiple of the true correlation time")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--tau-given-range", setup.tau_given_range,
                 "the 'tau given' rows are given a range of correlation times, from that tau / "
                 "this to that tau x this")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  app.add_option("--size-given-factor", setup.size_given_factor,
                 "the 'unit given' rows are told this multiple of the simulated wander's size")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--static-hours", setup.static_hours,
                 "the 'unit given' rows are given a static recording of the unit this many "
                 "hours long (one per run), as `--unit-static-recording` gives it")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--warmup-hours", setup.warmup_hours,
                 "the programme's warm-up (its warmup_s: the first position held this many "
                 "hours before its dwell, recorded, out of its mean): the 'estimated' rows take "
                 "its Allan curves' wander, as standcal fit does")
      ->check(CLI::Range(0.0, kMaxDwell_s / 3600));
  CLI::Option* transient =
      app.add_option("--warmup-transient-ug", setup.warmup_transient_ug,
                     "add a bias settling after power-on, this size x exp(-t / tau) on every axis "
                     "from the run's start (a warm-up that still drifts thermally)")
          ->check(CLI::Range(0.0, 1e6));
  app.add_option("--warmup-transient-tau-s", setup.warmup_transient_tau_s,
                 "the time constant of that settling")
      ->check(CLI::Range(1e-3, 1e7))
      ->needs(transient)
      ->capture_default_str();
  app.add_option("--specified-exceeded-p", setup.specified_exceeded_p,
                 "the 'unit given' rows weight with the run's own wander where it exceeds the "
                 "given one at this P")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--weighting-lr", setup.weighting_lr,
                 "weight for an estimated wander once 2 delta log L exceeds this")
      ->capture_default_str();
  app.add_option("--output-filter-tau-s", setup.output_filter_tau_s,
                 "the unit's output filter: first-order low-pass of the white noise (s)")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  setup.unit_given_rows = true;
  if (tau_max_s > 0 && tau_max_s <= tau_s) {
    std::fprintf(stderr, "--tau-max-s %g must exceed --tau-s %g (the range tau is drawn from)\n",
                 tau_max_s, tau_s);
    return 2;
  }
  setup.program =
      repeated_program(program == "diagnostic32" ? diagnostic32() : load_program(program), repeat);
  if (setup.warmup_hours > 0) setup.program.warmup_s = setup.warmup_hours * 3600;

  std::printf(
      "noise honesty: %d runs per scenario of %s (%zu positions, %.0f s dwells at %.0f Hz), "
      "%d threads\n",
      setup.runs, setup.program.name.c_str(), setup.program.positions.size(), setup.dwell_s,
      setup.sample_rate_hz, setup.threads);
  std::printf(
      "z-variance of an honest sigma: 1 (sd %.2f for %d runs); 'wand.' = runs whose fit "
      "found the wander significant; 'min cover' = the smallest share of runs, over the "
      "parameters, whose truth lies within +-1.96 sigma (95 %% if honest)\n",
      std::sqrt(2.0 / setup.runs), setup.runs);
  if (setup.output_filter_tau_s > 0)
    std::printf("the unit's output filter: %.3g s (samples correlated within a dwell)\n",
                setup.output_filter_tau_s);
  if (setup.tau_given_factor != 1 || setup.tau_given_range != 1)
    std::printf("'tau given': %.3g x the simulated correlation time, within a factor %.3g\n",
                setup.tau_given_factor, setup.tau_given_range);
  if (setup.warmup_hours > 0)
    std::printf(
        "a warm-up of %.3g hours before the first position's dwell (out of its mean): the "
        "'estimated' fits take its Allan curves' wander where they pin one\n",
        setup.warmup_hours);
  if (setup.warmup_transient_ug > 0)
    std::printf(
        "a bias settling after power-on: %.3g ug x exp(-t / %.4g s) on every axis, which the "
        "fits' models leave out\n",
        setup.warmup_transient_ug, setup.warmup_transient_tau_s);
  if (setup.static_hours > 0)
    std::printf(
        "'unit given': a %.3g-hour static recording of the unit at %.0f Hz, as "
        "--unit-static-recording gives it (each axis's size and the correlation times its "
        "curves pin, else the bound they set)\n",
        setup.static_hours, kStaticRecordingRateHz);
  else
    std::printf(
        "'unit given': that correlation time and %.3g x the simulated wander's size given, "
        "weighted with where the run does not show a wander\n",
        setup.size_given_factor);
  const auto start = std::chrono::steady_clock::now();
  for (Scenario s : issue21_scenarios()) {
    s.tau_s = tau_s;
    s.tau_max_s = tau_max_s;
    print_result(run_scenario(setup, s));
  }
  std::printf("\n%.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}
