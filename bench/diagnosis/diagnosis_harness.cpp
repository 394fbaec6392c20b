// The blind harness of the model-mismatch diagnosis (issue 6, docs/diagnosis.md).
// Each seeded trial draws an effect of the catalog (or none), a size between 3x and 10x
// its discrimination threshold on the harness programme, an axis, and random unit and
// stand errors; simulates the run with calib's simulator; diagnoses it without telling
// the diagnosis anything; and scores the first finding against the truth. Prints the
// thresholds, a confusion matrix and the three figures the issue sets targets for.
//
//   bench_diagnosis_harness [--trials N] [--seed S] [--verbose] [--only TRIAL]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"

using namespace standcal;

namespace {

// The harness programme and run: diagnostic32, 10 s dwells, 2 s settle, 100 Hz, 10 ug/rtHz,
// and a climatic chamber that ramps 10 degC/h with a 2 degC, 600 s cycle on top (so a bias
// temperature coefficient is not collinear with a bias drift, as it is under a pure ramp).
SimulationRequest harness_request(const TruthModel& truth, std::uint64_t seed) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = truth;
  req.truth.temperature.rate_c_per_h = 10;
  req.truth.temperature.cycle_amplitude_c = 2;
  req.truth.temperature.cycle_period_s = 600;
  req.seed = seed;
  req.timing.dwell_s = 10;
  req.timing.settle_s = 2;
  return req;
}

double uniform(std::mt19937_64& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
double signed_uniform(std::mt19937_64& rng, double lo, double hi) {
  return (std::bernoulli_distribution(0.5)(rng) ? 1 : -1) * uniform(rng, lo, hi);
}

// A navigation-grade unit on a well-adjusted stand, errors drawn inside model.md's ranges.
TruthModel random_truth(std::mt19937_64& rng) {
  TruthModel t = default_truth();
  for (int a = 0; a < 3; ++a) {
    t.unit.bias_g[a] = signed_uniform(rng, 20, 100) * kUg;
    t.unit.scale[a] = signed_uniform(rng, 50, 500) * kPpm;
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t.unit.gamma_rad(i, j) = i == j ? 0 : signed_uniform(rng, 5, 30) * kArcsecToRad;
  StandErrors& s = t.stand;
  s.levelling_x_rad = signed_uniform(rng, 1, 2) * kArcsecToRad;
  s.levelling_z_rad = signed_uniform(rng, 1, 2) * kArcsecToRad;
  s.alpha1_offset_rad = signed_uniform(rng, 1, 3) * kArcsecToRad;
  s.alpha2_offset_rad = signed_uniform(rng, 1, 3) * kArcsecToRad;
  s.skew_y_rad = signed_uniform(rng, 2, 5) * kArcsecToRad;
  s.skew_z_rad = signed_uniform(rng, 2, 5) * kArcsecToRad;
  for (int a = 0; a < 3; ++a) s.mounting_rad[0][a] = signed_uniform(rng, 10, 60) * kArcsecToRad;
  return t;
}

struct Drawn {
  std::string effect = "none", axis;
  double value = 0, tau_s = 0, phase_deg = 0, threshold = 0;
};

std::string label(const std::string& effect, const std::string& axis) { return effect == "none" ? "none" : effect + " " + axis; }

struct Outcome {
  Drawn truth;
  std::string found_effect = "none", found_axis;
  std::string verdict;
  double value = 0, sigma = 0, truth_value = 0;
  std::size_t findings = 0;
  bool right = false, within_3sigma = false;
};

Outcome run_trial(int trial, std::uint64_t seed, const std::vector<DiscriminationThreshold>& thresholds, bool verbose) {
  std::mt19937_64 rng(seed * 1000003ULL + static_cast<std::uint64_t>(trial));
  TruthModel truth = random_truth(rng);
  Outcome o;
  // One trial in five is effect-free (the false-finding rate needs enough of them).
  if (trial % 5 != 0) {
    std::vector<std::string> ids;
    for (const auto& t : thresholds)
      if (std::isfinite(t.threshold) && std::find(ids.begin(), ids.end(), t.effect) == ids.end()) ids.push_back(t.effect);
    const std::string id = ids[std::uniform_int_distribution<std::size_t>(0, ids.size() - 1)(rng)];
    std::vector<const DiscriminationThreshold*> axes;
    for (const auto& t : thresholds)
      if (t.effect == id && std::isfinite(t.threshold) &&
          (id != "settling_transient" || t.tau_s == 2 || t.tau_s == 4 || t.tau_s == 8))
        axes.push_back(&t);
    const DiscriminationThreshold& th = *axes[std::uniform_int_distribution<std::size_t>(0, axes.size() - 1)(rng)];
    Drawn& d = o.truth;
    d.effect = id;
    d.axis = th.axis;
    d.tau_s = th.tau_s;
    d.threshold = th.threshold;
    d.value = uniform(rng, 3, 10) * th.threshold;
    if (id == "angle_sensor_error") {
      d.phase_deg = uniform(rng, -180, 180);
    } else {
      if (std::bernoulli_distribution(0.5)(rng)) d.value = -d.value;
    }
    if (id == "mounting_misalignment_large") {
      truth.stand.mounting_rad[0][static_cast<int>(std::string("xyz").find(d.axis))] = d.value * kArcminToRad;
    } else {
      ExtraEffect e{id, d.axis, d.value, d.tau_s, d.phase_deg};
      truth.extra_physics.push_back(e);
    }
  }
  const Recording rec = simulate_run(harness_request(truth, seed * 7919ULL + static_cast<std::uint64_t>(trial)));
  const Diagnosis diag = diagnose_recording(rec);
  o.verdict = diag.verdict;
  o.findings = diag.findings.size();
  if (diag.verdict == "ambiguous") {
    o.found_effect = "ambiguous";
  } else if (!diag.findings.empty()) {
    const Finding& f = diag.findings.front();
    o.found_effect = f.effect;
    o.found_axis = f.axis;
    o.value = f.value;
    o.sigma = f.sigma;
  }
  o.truth_value = o.truth.value;
  if (o.truth.effect == "mounting_misalignment_large")  // what gravity can see: model.md's combination
    o.truth_value = identifiable_mounting_rad(truth)[static_cast<int>(std::string("xyz").find(o.truth.axis))] / kArcminToRad;
  o.right = o.truth.effect != "none" && o.found_effect == o.truth.effect && o.found_axis == o.truth.axis;
  o.within_3sigma = o.right && std::abs(o.value - o.truth_value) < 3 * o.sigma;
  if (verbose || (o.truth.effect != "none" && !o.within_3sigma) || (o.truth.effect == "none" && o.findings > 0)) {
    std::printf("trial %3d: truth %-34s %+10.3f (%.1fx thr%s) -> %-9s %-34s", trial, label(o.truth.effect, o.truth.axis).c_str(),
                o.truth_value, o.truth.threshold > 0 ? std::abs(o.truth.value) / o.truth.threshold : 0.0,
                o.truth.tau_s > 0 ? (", tau " + std::to_string(static_cast<int>(o.truth.tau_s)) + " s").c_str() : "",
                o.verdict.c_str(), label(o.found_effect, o.found_axis).c_str());
    if (o.found_effect != "none" && o.found_effect != "ambiguous") std::printf(" %+10.3f +- %.3f", o.value, o.sigma);
    std::printf("%s\n", o.truth.effect != "none" && o.right && !o.within_3sigma ? "  (value beyond 3 sigma)" : "");
    if (verbose || o.verdict == "ambiguous" || (!o.right && o.truth.effect != "none"))
      for (const auto& s : diag.summary) std::printf("           %s\n", s.c_str());
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 200;
  std::uint64_t seed = 1;
  bool verbose = false;
  int only = -1;  // run just this trial (with --verbose: to look at one case)
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--trials" && i + 1 < argc) trials = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--verbose") verbose = true;
    else if (a == "--only" && i + 1 < argc) only = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--trials N] [--seed S] [--verbose] [--only TRIAL]\n", argv[0]);
      return 2;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  // Thresholds from an effect-free recording of the harness run (design and noise only).
  const std::vector<DiscriminationThreshold> thresholds = discrimination_thresholds(simulate_run(harness_request(default_truth(), 99)));
  std::printf("Discrimination thresholds on diagnostic32 (10 s dwell, 10 ug/rtHz, chamber 10 degC/h + 2 degC/600 s):\n");
  for (const auto& t : thresholds)
    std::printf("  %-28s %-6s %s %10.3f %-9s nearest: %s\n", t.effect.c_str(), t.axis.c_str(),
                t.tau_s > 0 ? ("tau " + std::to_string(static_cast<int>(t.tau_s)) + "s").c_str() : "      ", t.threshold,
                t.unit.c_str(), t.nearest.c_str());

  std::vector<Outcome> outcomes;
  for (int i = 0; i < trials; ++i)
    if (only < 0 || i == only) outcomes.push_back(run_trial(i, seed, thresholds, verbose));
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Confusion matrix by effect id (rows: truth, columns: first finding); axis in the last column.
  std::vector<std::string> ids{"none"};
  for (const auto& t : thresholds)
    if (std::find(ids.begin(), ids.end(), t.effect) == ids.end()) ids.push_back(t.effect);
  std::vector<std::string> cols = ids;
  cols.push_back("ambiguous");
  std::map<std::string, std::map<std::string, int>> matrix;
  std::map<std::string, int> axis_right, row_total;
  for (const Outcome& o : outcomes) {
    const std::string found = std::find(cols.begin(), cols.end(), o.found_effect) != cols.end() ? o.found_effect : "ambiguous";
    ++matrix[o.truth.effect][found];
    ++row_total[o.truth.effect];
    if (o.right) ++axis_right[o.truth.effect];
  }
  auto short_name = [](const std::string& id) {
    static const std::map<std::string, std::string> s{
        {"none", "none"}, {"scale_nonlinearity_k2", "K2"}, {"scale_nonlinearity_k3", "K3"}, {"bias_drift", "drift"},
        {"hysteresis", "hyst"}, {"bias_temperature", "bT"}, {"scale_temperature", "kT"}, {"cross_coupling", "Kij"},
        {"angle_sensor_error", "angle"}, {"settling_transient", "settle"}, {"mounting_misalignment_large", "mount"},
        {"scale_asymmetry", "Koq"}, {"stand_level_drift", "level"}, {"ambiguous", "ambig"}};
    const auto it = s.find(id);
    return it == s.end() ? id : it->second;
  };
  std::printf("\nConfusion matrix (%d trials; rows: drawn effect, columns: the diagnosis's first finding;\n"
              "'id+axis' counts first findings with the right id AND axis):\n%-30s", trials, "drawn \\ found");
  for (const auto& c : cols) std::printf("%7s", short_name(c).c_str());
  std::printf("%9s\n", "id+axis");
  for (const auto& r : ids) {
    if (!row_total[r]) continue;
    std::printf("%-30s", r.c_str());
    for (const auto& c : cols) std::printf("%7d", matrix[r][c]);
    std::printf("%6d/%-3d\n", axis_right[r], row_total[r]);
  }

  int with_effect = 0, right = 0, within = 0, free = 0, free_findings = 0;
  for (const Outcome& o : outcomes) {
    if (o.truth.effect == "none") {
      ++free;
      free_findings += o.findings > 0 ? 1 : 0;
    } else {
      ++with_effect;
      right += o.right ? 1 : 0;
      within += o.within_3sigma ? 1 : 0;
    }
  }
  auto pct = [](int a, int b) { return b > 0 ? 100.0 * a / b : 0.0; };
  std::printf("\nidentified (right id and axis):      %3d / %3d = %5.1f %%   (target >= 95 %%)\n", right, with_effect, pct(right, with_effect));
  std::printf("value within 3 sigma of the truth:   %3d / %3d = %5.1f %%   (target >= 95 %% of those identified)\n", within, right, pct(within, right));
  std::printf("findings on effect-free recordings:  %3d / %3d = %5.1f %%   (target <= 5 %%)\n", free_findings, free, pct(free_findings, free));
  std::printf("time: %.1f s for %d trials (%.2f s per simulate + diagnose)\n", elapsed_s, trials, elapsed_s / trials);
  return 0;
}
