// The blind harness of the model-mismatch diagnosis (issue 15, docs/diagnosis.md). The
// recordings come from bench/diagnosis/effect_generator, written independently of calib's
// simulator. Each seeded trial draws one of: no effect (white noise), no effect (coloured
// noise), one catalog effect (3x-10x its discrimination threshold), one effect that is in
// no catalog (where only `unexplained` is right), or a pair of catalog effects (5x-10x
// each); random unit and stand errors; and diagnoses the recording without telling it
// anything. Prints the thresholds, how much of each uncatalogued effect the catalog cannot
// explain, a confusion matrix, the target figures, and the power table: detection
// rate at 1x, 2x, 3x, 5x the threshold beside the ideal likelihood-ratio test's power.
//
//   bench_diagnosis_harness [--trials N] [--seed S] [--verbose] [--only TRIAL] [--power-trials N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "bench/diagnosis/harness_trials.hpp"

using namespace standcal;
using namespace standcal::bench;

namespace {

struct Options {
  int trials = 200;
  std::uint64_t seed = 1;
  bool verbose = false;
  int only = -1;  // run just this trial (with --verbose: to look at one case); no power table
  int power_trials = 40;
};

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--trials" && has_value)
      o.trials = std::atoi(argv[++i]);
    else if (a == "--seed" && has_value)
      o.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--verbose")
      o.verbose = true;
    else if (a == "--only" && has_value)
      o.only = std::atoi(argv[++i]);
    else if (a == "--power-trials" && has_value)
      o.power_trials = std::atoi(argv[++i]);
    else
      return false;
  }
  return o.trials >= 0 && o.power_trials >= 0;
}

double pct(int a, int b) { return b > 0 ? 100.0 * a / b : 0.0; }

std::string short_name(const std::string& id) {
  static const std::map<std::string, std::string> names{
      {"scale_nonlinearity_k2", "K2"},  {"scale_nonlinearity_k3", "K3"},
      {"bias_drift", "drift"},          {"hysteresis", "hyst"},
      {"bias_temperature", "bT"},       {"scale_temperature", "kT"},
      {"cross_coupling", "Kij"},        {"angle_sensor_error", "angle"},
      {"settling_transient", "settle"}, {"mounting_misalignment_large", "mount"},
      {"scale_asymmetry", "asym"},      {"stand_level_drift", "level"}};
  const auto it = names.find(id);
  return it == names.end() ? id : it->second;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

std::string tau_words(double tau_s) {
  return tau_s > 0 ? "tau " + std::to_string(static_cast<int>(tau_s)) + "s" : "";
}

void print_thresholds(const HarnessSetup& setup) {
  std::printf(
      "Discrimination thresholds on diagnostic32 (10 s dwell, 10 ug/rtHz, chamber 10 degC/h\n"
      "+ 2 degC/600 s), effect-free reference recording of the generator. 'generator': the same\n"
      "definition computed from generator-made leftovers after fit_full_vector, with every\n"
      "catalog term as a competitor (the two the diagnosis does not know yet too):\n");
  std::printf("  %-28s %-6s %-7s %11s %-9s %-34s %11s  %s\n", "id", "axis", "", "diagnosis", "unit",
              "nearest", "generator", "nearest");
  for (const Threshold& t : setup.thresholds) {
    const std::string diag = t.from_diagnosis ? number(t.value) : "(unknown)";
    const std::string own = std::isfinite(t.generator_value) ? number(t.generator_value) : "-";
    std::printf("  %-28s %-6s %-7s %11s %-9s %-34s %11s  %s\n", t.id.c_str(), t.axis.c_str(),
                tau_words(t.tau_s).c_str(), diag.c_str(), t.unit.c_str(),
                t.from_diagnosis ? t.nearest.c_str() : "", own.c_str(),
                t.generator_nearest.c_str());
  }
  std::printf(
      "  (settling and large mounting: the diagnosis's only. 'unknown': not in the diagnosis's\n"
      "   catalog yet; the harness draws it at multiples of the generator-made threshold.)\n");
  std::printf("Not drawn (3x the threshold is beyond %g x typical_max, an implausible size):",
              DiagnoseOptions{}.implausible_factor);
  for (const Threshold& t : setup.thresholds)
    if (std::isfinite(t.value) && plausible_multiple(t) < 3)
      std::printf(" %s %s%s;", t.id.c_str(), t.axis.c_str(),
                  t.tau_s > 0 ? (" " + tau_words(t.tau_s)).c_str() : "");
  std::printf("\n");
}

// How much of each uncatalogued effect no combination of catalog terms explains, in the
// per-position means: near 0 the effect would be a catalog combination in disguise. The
// harness sizes each draw so that this part is 10-30 sigma.
void print_uncatalogued_check(const HarnessSetup& setup, std::uint64_t seed) {
  std::printf(
      "\nUncatalogued effects as drawn (20 draws each): the fraction of their per-position\n"
      "pattern that the baseline plus ALL catalog terms together cannot explain (each drawn at\n"
      "10-30 sigma of that part):\n");
  for (const char* id : {"bias_jump", "angle_sensor_harmonic2", "bias_oscillation"}) {
    std::vector<double> fractions, sizes;
    for (int i = 0; i < 20; ++i) {
      const Trial t = uncatalogued_trial(500000 + i, seed, setup, id);
      const Eigen::VectorXd r =
          baseline_leftover(t.truth.effects, setup.chamber, setup.run, setup.reference);
      fractions.push_back(unexplained_norm(r, setup.catalog) / r.norm());
      sizes.push_back(std::abs(t.drawn.front().effect.value));
    }
    std::sort(fractions.begin(), fractions.end());
    std::sort(sizes.begin(), sizes.end());
    std::printf("  %-24s fraction %.2f .. %.2f (median %.2f);  |value| %.1f .. %.1f %s\n", id,
                fractions.front(), fractions.back(), fractions[10], sizes.front(), sizes.back(),
                effect_spec(id).unit.c_str());
  }
}

std::string describe(const Drawn& d) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s %s %+.3f", d.effect.id.c_str(), d.effect.axis.c_str(),
                d.effect.value);
  std::string s = buf;
  if (d.effect.id == "mounting_misalignment_large")
    s += " (gravity sees " + number(d.expected) + ")";
  if (d.threshold > 0) s += " (" + number(std::abs(d.effect.value) / d.threshold) + "x thr)";
  if (d.effect.tau_s > 0 && d.effect.id == "settling_transient")
    s += " " + tau_words(d.effect.tau_s);
  if (d.effect.id == "bias_jump")
    s += " at " + std::to_string(static_cast<int>(d.effect.time_s)) + " s";
  return s;
}

std::string describe(const Trial& t) {
  if (t.drawn.empty()) return kind_name(t.kind);
  std::string s;
  for (const Drawn& d : t.drawn) s += (s.empty() ? "" : " + ") + describe(d);
  return s;
}

void print_trial(const Trial& t, const Outcome& o, bool verbose) {
  std::printf("trial %3d: %s -> %s", t.index, describe(t).c_str(), o.verdict.c_str());
  for (const Finding& f : o.findings)
    std::printf(", %s %s %+.3f +- %.3f", f.effect.c_str(), f.axis.c_str(), f.value, f.sigma);
  std::printf("%s\n", o.found > o.within_3sigma ? "  (value beyond 3 sigma)" : "");
  if (verbose)  // the diagnosis's own words: with --verbose (and --only, to look at one case)
    for (const auto& s : o.summary) std::printf("           %s\n", s.c_str());
}

// Confusion-matrix row of a trial: the kind, or the drawn id for single effects.
std::string row_of(const Trial& t) {
  if (t.kind == TrialKind::catalog) return t.drawn.front().effect.id;
  if (t.kind == TrialKind::uncatalogued) return "uncatalogued: " + t.drawn.front().effect.id;
  return kind_name(t.kind);
}

// Column: the first deterministic finding when the verdict is explained, else the verdict.
std::string column_of(const Outcome& o) {
  if (o.verdict == "consistent") return "none";
  if (o.verdict == "explained")
    return o.findings.empty() ? "other" : short_name(o.findings.front().effect);
  if (o.verdict == "unexplained") return "unexpl";
  if (o.verdict == "ambiguous") return "ambig";
  if (o.verdict == "insufficient_redundancy") return "insuff";
  return "other";
}

struct Scored {
  Trial trial;
  Outcome outcome;
};

void print_confusion(const std::vector<Scored>& scored, const HarnessSetup& setup) {
  std::vector<std::string> rows{kind_name(TrialKind::white), kind_name(TrialKind::coloured)};
  std::vector<std::string> cols{"none"};
  for (const Threshold& t : setup.thresholds) {
    if (std::find(rows.begin(), rows.end(), t.id) == rows.end()) rows.push_back(t.id);
    if (std::find(cols.begin(), cols.end(), short_name(t.id)) == cols.end())
      cols.push_back(short_name(t.id));
  }
  for (const char* id : {"bias_jump", "angle_sensor_harmonic2", "bias_oscillation"})
    rows.push_back(std::string("uncatalogued: ") + id);
  rows.push_back(kind_name(TrialKind::pair));
  for (const char* c : {"unexpl", "ambig", "insuff", "other"}) cols.push_back(c);
  std::map<std::string, std::map<std::string, int>> matrix;
  std::map<std::string, int> right, total, explained;
  for (const Scored& s : scored) {
    const std::string r = row_of(s.trial);
    ++matrix[r][column_of(s.outcome)];
    ++total[r];
    right[r] += s.outcome.right ? 1 : 0;
    explained[r] += s.outcome.verdict == "explained" ? 1 : 0;
  }
  std::printf(
      "\nConfusion matrix (%zu trials). Rows: what was concealed. Columns: the first finding when\n"
      "the verdict is 'explained', else the verdict ('none' = consistent). 'right' by the rule of\n"
      "the row's kind; 'expl' counts 'explained' verdicts (failures on the uncatalogued rows).\n"
      "%-36s",
      scored.size(), "concealed \\ said");
  for (const auto& c : cols) std::printf("%7s", c.c_str());
  std::printf("%9s%6s\n", "right", "expl");
  for (const auto& r : rows) {
    if (!total[r]) continue;
    std::printf("%-36s", r.c_str());
    for (const auto& c : cols) std::printf("%7d", matrix[r][c]);
    std::printf("%5d/%-3d%6d\n", right[r], total[r], explained[r]);
  }
}

// What the targets are about, counted over the trials.
struct Tally {
  std::map<TrialKind, int> right, total, beyond_concealed;
  int all_right = 0, found = 0, within = 0, uncatalogued_explained = 0;
  int false_white = 0, false_coloured = 0;
  int coloured_right_unspecified = 0;  // the same recordings without the unit's specification
};

Tally tally(const std::vector<Scored>& scored) {
  Tally t;
  for (const auto& [trial, o] : scored) {
    const TrialKind k = trial.kind;
    ++t.total[k];
    t.right[k] += o.right ? 1 : 0;
    t.all_right += o.right ? 1 : 0;
    t.found += o.found;
    t.within += o.within_3sigma;
    t.uncatalogued_explained += k == TrialKind::uncatalogued && o.verdict == "explained";
    t.false_white += k == TrialKind::white && o.false_finding;
    t.false_coloured += k == TrialKind::coloured && o.false_finding;
    t.coloured_right_unspecified += k == TrialKind::coloured && o.right_unspecified;
    t.beyond_concealed[k] += o.findings.size() > trial.drawn.size();
  }
  return t;
}

void print_targets(const std::vector<Scored>& scored, double elapsed_s) {
  Tally t = tally(scored);
  const int n = static_cast<int>(scored.size());
  const auto line = [](const char* what, int a, int b, const char* target) {
    std::printf("%-52s %4d / %4d = %5.1f %%%s%s\n", what, a, b, pct(a, b), *target ? "   " : "",
                target);
  };
  const auto kind_line = [&t, &line](const char* what, TrialKind k) {
    line(what, t.right[k], t.total[k], "");
  };
  std::printf("\n");
  line("right overall:", t.all_right, n, "(target >= 95 %)");
  kind_line("  one catalog effect found, right axis, explained:", TrialKind::catalog);
  kind_line("  pairs: both found, explained:", TrialKind::pair);
  kind_line("  uncatalogued: unexplained:", TrialKind::uncatalogued);
  kind_line("  effect-free (white): consistent, nothing found:", TrialKind::white);
  kind_line("  effect-free (coloured): consistent, nothing found:", TrialKind::coloured);
  line("uncatalogued effects 'explained':", t.uncatalogued_explained,
       t.total[TrialKind::uncatalogued], "(target 0)");
  line("false findings, white noise:", t.false_white, t.total[TrialKind::white], "(target <= 1 %)");
  line("false findings, coloured noise:", t.false_coloured, t.total[TrialKind::coloured],
       "(target <= 1 %)");
  line("  coloured, without the unit's specified wander:", t.coloured_right_unspecified,
       t.total[TrialKind::coloured], "consistent, nothing found");
  line("found catalog values within 3 sigma of the truth:", t.within, t.found,
       "(docs/diagnosis.md: >= 95 %)");
  line("catalog trials with findings beyond the concealed:", t.beyond_concealed[TrialKind::catalog],
       t.total[TrialKind::catalog], "");
  line("pair trials with findings beyond the concealed:", t.beyond_concealed[TrialKind::pair],
       t.total[TrialKind::pair], "");
  std::printf("time: %.1f s for %d trials (%.3f s per generate + diagnose)\n", elapsed_s, n,
              n > 0 ? elapsed_s / n : 0.0);
}

// One axis of every catalog id for the power table (settling at tau 4 s).
struct PowerTerm {
  const char* id;
  const char* axis;
  double tau_s;
};
const std::vector<PowerTerm> kPowerTerms{{"scale_nonlinearity_k2", "z", 0},
                                         {"scale_nonlinearity_k3", "x", 0},
                                         {"cross_coupling", "xy", 0},
                                         {"bias_temperature", "y", 0},
                                         {"scale_temperature", "z", 0},
                                         {"bias_drift", "x", 0},
                                         {"hysteresis", "y", 0},
                                         {"settling_transient", "z", 4},
                                         {"mounting_misalignment_large", "y", 0},
                                         {"angle_sensor_error", "alpha1", 0},
                                         {"scale_asymmetry", "x", 0},
                                         {"stand_level_drift", "z", 0}};
const double kPowerMultiples[4] = {1, 2, 3, 5};

// Detection rate and mean ideal power (both in %) of one term at one multiple of its threshold.
struct PowerCell {
  double rate_pct = 0, ideal_pct = 0;
};

PowerCell measure_power(const Threshold& term, double multiple, int first_index,
                        const HarnessSetup& setup, const Options& o) {
  int detected = 0;
  double ideal = 0;
  for (int i = 0; i < o.power_trials; ++i) {
    const PowerPoint p =
        power_trial(catalog_trial(first_index + i, o.seed, setup, term, multiple), setup);
    detected += p.detected ? 1 : 0;
    ideal += p.ideal_power;
  }
  return {pct(detected, o.power_trials), 100 * ideal / std::max(o.power_trials, 1)};
}

void print_power(const HarnessSetup& setup, const Options& o) {
  std::printf(
      "\nPower: detection rate of the diagnosis (its findings name the id and axis) beside the\n"
      "ideal likelihood-ratio test, which knows the term's shape: lambda = the chi2 the "
      "full-vector\n"
      "baseline leaves of the noise-free effect alone (plus its within-dwell part on the "
      "samples),\n"
      "critical value 16 for one parameter, 19.3 for two (angle, settling); large mounting: the\n"
      "size test (|psi| - tolerance) / sigma > 4. %d trials per cell, white noise, random unit\n"
      "and stand errors. Cells: rate/ideal.\n",
      o.power_trials);
  std::printf("%-28s %-6s %11s  %-11s%-11s%-11s%-11s %s\n", "id", "axis", "threshold", "1x", "2x",
              "3x", "5x", "targets: 3x >= 95 %, 2x within 10 points");
  for (std::size_t term_i = 0; term_i < kPowerTerms.size(); ++term_i) {
    const PowerTerm& p = kPowerTerms[term_i];
    const Threshold& term = threshold_of(setup, p.id, p.axis, p.tau_s);
    std::printf("%-28s %-6s %11.3f  ", p.id, p.axis, term.value);
    if (plausible_multiple(term) < 3) {
      std::printf("not drawn: 3x is beyond a plausible size (%.0f x typical_max)\n",
                  DiagnoseOptions{}.implausible_factor);
      continue;
    }
    PowerCell cells[4];
    for (int m = 0; m < 4; ++m) {
      // Trials of their own seeds: 1000 per cell (so at most 1000 power trials).
      const int first_index = 1000000 + static_cast<int>(term_i) * 10000 + m * 1000;
      cells[m] = measure_power(term, kPowerMultiples[m], first_index, setup, o);
      std::printf("%3.0f/%3.0f    ", cells[m].rate_pct, cells[m].ideal_pct);
    }
    const bool at3 = cells[2].rate_pct >= 95, at2 = cells[1].ideal_pct - cells[1].rate_pct <= 10;
    std::printf(" 3x %-4s  2x %s%s\n", at3 ? "ok" : "MISS", at2 ? "ok" : "MISS",
                term.from_diagnosis ? "" : "    (not in the diagnosis's catalog)");
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) {
    std::fprintf(
        stderr, "usage: %s [--trials N] [--seed S] [--verbose] [--only TRIAL] [--power-trials N]\n",
        argv[0]);
    return 2;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const HarnessSetup setup = harness_setup();
  print_thresholds(setup);
  print_uncatalogued_check(setup, o.seed);
  std::printf("\n");

  const auto t_trials = std::chrono::steady_clock::now();
  std::vector<Scored> scored;
  for (int i = 0; i < o.trials; ++i) {
    if (o.only >= 0 && i != o.only) continue;
    const Trial t = draw_trial(i, o.seed, setup);
    const Recording rec = record(t, setup);
    Outcome out = diagnose_trial(t, rec);
    if (t.kind == TrialKind::coloured) out.right_unspecified = diagnose_trial(t, rec, true).right;
    if (o.verbose || !out.right || out.found > out.within_3sigma) print_trial(t, out, o.verbose);
    scored.push_back({t, out});
  }
  const double trials_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_trials).count();
  print_confusion(scored, setup);
  print_targets(scored, trials_s);
  if (o.only < 0 && o.power_trials > 0) print_power(setup, o);
  std::printf("\nwall time: %.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}
