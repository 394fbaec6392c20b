#include "bench/diagnosis/harness_trials.hpp"

#include "calib/diagnosis/catalog.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"

namespace standcal::bench {

namespace {

using Rng = std::mt19937_64;

// The uncatalogued bias oscillation's period: 7 minutes, unrelated to the chamber's 10-minute
// cycle, so no temperature term can follow it.
constexpr double kOscillationPeriod_s = 420;

double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
double random_sign(Rng& rng) { return std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0; }
double signed_uniform(Rng& rng, double lo, double hi) {
  return random_sign(rng) * uniform(rng, lo, hi);
}
template <typename T>
const T& pick(Rng& rng, const std::vector<T>& items) {
  return items[std::uniform_int_distribution<std::size_t>(0, items.size() - 1)(rng)];
}

Rng trial_rng(int index, std::uint64_t seed) {
  return Rng(seed * 1000003ULL + static_cast<std::uint64_t>(index));
}

// A navigation-grade unit on a well-adjusted stand, errors inside model.md's ranges.
GeneratorTruth random_truth(Rng& rng, const HarnessSetup& setup) {
  GeneratorTruth t;
  t.chamber = setup.chamber;
  for (int a = 0; a < 3; ++a) {
    t.unit.bias_g[a] = signed_uniform(rng, 20, 100) * kUg;
    t.unit.scale[a] = signed_uniform(rng, 50, 500) * kPpm;
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      t.unit.gamma_rad(i, j) = i == j ? 0 : signed_uniform(rng, 5, 30) * kArcsecToRad;
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

Trial new_trial(int index, TrialKind kind, std::uint64_t seed, Rng& rng,
                const HarnessSetup& setup) {
  Trial t;
  t.index = index;
  t.kind = kind;
  t.generator_seed = seed * 7919ULL + static_cast<std::uint64_t>(index);
  t.truth = random_truth(rng, setup);
  return t;
}

// What the diagnosis should report for a drawn catalog effect, once the whole truth is drawn.
double expected_value(const ConcealedEffect& e, const GeneratorTruth& truth) {
  if (e.id == "angle_sensor_error") return std::abs(e.value);  // reported as amplitude and phase
  if (e.id != "mounting_misalignment_large") return e.value;
  // Gravity sees the mounting composed with the antisymmetric gamma and the inner-axis zero.
  TruthModel model;
  model.unit = truth.unit;
  model.stand = truth.stand;
  for (const ConcealedEffect& m : truth.effects)
    if (m.id == e.id)
      model.stand.mounting_rad[0][static_cast<int>(std::string("xyz").find(m.axis))] +=
          m.value * kArcminToRad;
  return identifiable_mounting_rad(model)[static_cast<int>(std::string("xyz").find(e.axis))] /
         kArcminToRad;
}

}  // namespace

double plausible_multiple(const Threshold& t) {
  const diagnosis::CatalogEntry* e = diagnosis::find_catalog_entry(t.id);
  if (!e) return std::numeric_limits<double>::infinity();
  return DiagnoseOptions{}.implausible_factor * e->typical_max / t.value;
}

namespace {

void conceal(Trial& t, const Threshold& term, double multiple, Rng& rng) {
  ConcealedEffect e{term.id, term.axis, multiple * term.value, term.tau_s};
  if (e.id == "angle_sensor_error")
    e.phase_deg = uniform(rng, -180, 180);
  else
    e.value *= random_sign(rng);
  t.truth.effects.push_back(e);
  t.drawn.push_back({e, term.value, 0});
}

void settle_expected_values(Trial& t) {
  for (Drawn& d : t.drawn) d.expected = expected_value(d.effect, t.truth);
}

// A catalog term as the harness draws it: id uniformly, then an axis (settling: tau 2, 4 or
// 8 s) uniformly among that id's finite thresholds that a plausible size can reach at 3x.
const Threshold& draw_term(Rng& rng, const HarnessSetup& setup) {
  auto drawable = [](const Threshold& t) {
    return std::isfinite(t.value) && plausible_multiple(t) >= 3;
  };
  std::vector<std::string> ids;
  for (const Threshold& t : setup.thresholds)
    if (drawable(t) && std::find(ids.begin(), ids.end(), t.id) == ids.end()) ids.push_back(t.id);
  const std::string& id = pick(rng, ids);
  std::vector<const Threshold*> terms;
  for (const Threshold& t : setup.thresholds)
    if (t.id == id && drawable(t) &&
        (id != "settling_transient" || t.tau_s == 2 || t.tau_s == 4 || t.tau_s == 8))
      terms.push_back(&t);
  return *pick(rng, terms);
}

// A size between lo and hi times the threshold, but never beyond the plausible size.
double draw_multiple(Rng& rng, const Threshold& t, double lo, double hi) {
  return uniform(rng, lo, std::max(lo, std::min(hi, plausible_multiple(t))));
}

// An uncatalogued effect's shape (axis, phase, time) as drawn, and its size: 10-30 sigma of
// the part of its per-position pattern that no combination of all catalog terms explains,
// so that `unexplained` is the only right answer however the catalog is combined.
ConcealedEffect uncatalogued_effect(const std::string& id, Rng& rng, const HarnessSetup& setup) {
  constexpr double kProbe = 10;  // report unit: tens of ug, where the baseline fit is linear
  ConcealedEffect e{id, pick(rng, effect_spec(id).axes), kProbe};
  if (id == "bias_jump") e.time_s = uniform(rng, 0.3, 0.7) * setup.run_duration_s;
  if (id == "bias_oscillation") e.time_s = kOscillationPeriod_s;
  if (id != "bias_jump") e.phase_deg = uniform(rng, -180, 180);
  const Eigen::VectorXd probe = baseline_leftover({e}, setup.chamber, setup.run, setup.reference);
  const double sigma_per_probe = unexplained_norm(probe, setup.catalog);
  const double sign =
      id == "angle_sensor_harmonic2" ? 1.0 : random_sign(rng);  // an amplitude with a phase
  e.value = sign * kProbe * uniform(rng, 10, 30) / sigma_per_probe;
  return e;
}

void add_coloured_noise(Trial& t, Rng& rng) {
  for (const char* axis : {"x", "y", "z"})
    t.truth.effects.push_back(
        {"bias_instability", axis, uniform(rng, 2, 5), uniform(rng, 200, 400)});
}

void conceal_pair(Trial& t, Rng& rng, const HarnessSetup& setup) {
  const Threshold& first = draw_term(rng, setup);
  const Threshold* second = &draw_term(rng, setup);
  while (second->id == first.id && second->axis == first.axis) second = &draw_term(rng, setup);
  conceal(t, first, draw_multiple(rng, first, 5, 10), rng);
  conceal(t, *second, draw_multiple(rng, *second, 5, 10), rng);
}

void conceal_uncatalogued(Trial& t, const std::string& id, Rng& rng, const HarnessSetup& setup) {
  const ConcealedEffect e = uncatalogued_effect(id, rng, setup);
  t.truth.effects.push_back(e);
  t.drawn.push_back({e, 0, 0});
}

bool is_noise_finding(const Finding& f) {
  const auto& specs = effect_specs();
  return std::any_of(specs.begin(), specs.end(), [&f](const EffectSpec& s) {
    return s.id == f.effect && s.kind == EffectKind::noise;
  });
}

bool same_effect(const Finding& f, const ConcealedEffect& e) {
  return f.effect == e.id && f.axis == e.axis;
}

// Catalog trials: every drawn effect among the first (number drawn) findings, verdict explained.
void score_catalog(const Trial& trial, Outcome& o) {
  const auto top_end = o.findings.begin() +
                       static_cast<std::ptrdiff_t>(std::min(o.findings.size(), trial.drawn.size()));
  bool all_on_top = o.verdict == "explained";
  for (const Drawn& d : trial.drawn) {
    const auto on_top = std::find_if(o.findings.begin(), top_end,
                                     [&d](const Finding& f) { return same_effect(f, d.effect); });
    all_on_top = all_on_top && on_top != top_end;
    const auto it = std::find_if(o.findings.begin(), o.findings.end(),
                                 [&d](const Finding& f) { return same_effect(f, d.effect); });
    if (it == o.findings.end()) continue;
    ++o.found;
    o.within_3sigma += std::abs(it->value - d.expected) < 3 * it->sigma ? 1 : 0;
  }
  o.right = all_on_top;
}

double ideal_power(const Trial& trial, const Recording& rec, const HarnessSetup& setup) {
  const Drawn& d = trial.drawn.front();
  const DiagnoseOptions options;
  if (d.effect.id == "mounting_misalignment_large") {
    // A size test of a baseline parameter, |psi| against the tolerance: the threshold is
    // tolerance + 3 sigma, the finding needs (|psi| - tolerance) / sigma > 4.
    const double sigma = (d.threshold - options.mounting_tolerance_arcmin) / 3;
    const double excess = (std::abs(d.expected) - options.mounting_tolerance_arcmin) / sigma;
    return 0.5 * std::erfc(-(excess - std::sqrt(options.significance_chi2)) / std::sqrt(2.0));
  }
  const int params =
      d.effect.id == "angle_sensor_error" || d.effect.id == "settling_transient" ? 2 : 1;
  const double lambda = ideal_noncentrality(trial.truth, setup.run, average_positions(rec));
  return noncentral_chi2_tail(critical_chi2(params, options.significance_chi2), params, lambda);
}

}  // namespace

HarnessSetup harness_setup() {
  HarnessSetup s;
  GeneratorTruth reference_truth;
  reference_truth.chamber = s.chamber;
  const Recording reference = generate_recording(reference_truth, s.run, 99);
  s.reference = average_positions(reference);
  s.run_duration_s = reference.samples.back().t_s;
  s.catalog = catalog_leftovers(s.chamber, s.run, s.reference);
  for (const DiscriminationThreshold& d : discrimination_thresholds(reference))
    s.thresholds.push_back(
        {d.effect, d.axis, d.unit, d.tau_s, d.threshold, d.nearest, true, kNaN, ""});
  for (const TermLeftover& term : s.catalog) {
    std::string nearest;
    const double value = leftover_threshold(term, s.catalog, nearest);
    const auto known = std::find_if(
        s.thresholds.begin(), s.thresholds.end(),
        [&term](const Threshold& t) { return t.id == term.id && t.axis == term.axis; });
    if (known == s.thresholds.end()) {
      s.thresholds.push_back({term.id, term.axis, effect_spec(term.id).unit, 0, value, nearest,
                              false, value, nearest});
    } else {
      known->generator_value = value;
      known->generator_nearest = nearest;
    }
  }
  return s;
}

const Threshold& threshold_of(const HarnessSetup& setup, const std::string& id,
                              const std::string& axis, double tau_s) {
  for (const Threshold& t : setup.thresholds)
    if (t.id == id && t.axis == axis && t.tau_s == tau_s) return t;
  throw std::invalid_argument("harness: no threshold for " + id + " " + axis);
}

std::string kind_name(TrialKind kind) {
  switch (kind) {
    case TrialKind::white:
      return "none (white noise)";
    case TrialKind::coloured:
      return "none (coloured noise)";
    case TrialKind::catalog:
      return "catalog";
    case TrialKind::uncatalogued:
      return "uncatalogued";
    case TrialKind::pair:
      return "pair";
  }
  return "?";
}

TrialKind kind_of_trial(int index) {
  static const TrialKind cycle[10] = {
      TrialKind::white,   TrialKind::coloured, TrialKind::catalog,      TrialKind::catalog,
      TrialKind::catalog, TrialKind::catalog,  TrialKind::uncatalogued, TrialKind::uncatalogued,
      TrialKind::pair,    TrialKind::pair};
  return cycle[index % 10];
}

Trial draw_trial(int index, std::uint64_t seed, const HarnessSetup& setup) {
  static const std::vector<std::string> uncatalogued_ids{"bias_jump", "angle_sensor_harmonic2",
                                                         "bias_oscillation"};
  Rng rng = trial_rng(index, seed);
  Trial t = new_trial(index, kind_of_trial(index), seed, rng, setup);
  switch (t.kind) {
    case TrialKind::white:
      break;
    case TrialKind::coloured:
      add_coloured_noise(t, rng);
      break;
    case TrialKind::catalog: {
      const Threshold& term = draw_term(rng, setup);
      conceal(t, term, draw_multiple(rng, term, 3, 10), rng);
      break;
    }
    case TrialKind::uncatalogued:
      conceal_uncatalogued(t, pick(rng, uncatalogued_ids), rng, setup);
      break;
    case TrialKind::pair:
      conceal_pair(t, rng, setup);
      break;
  }
  settle_expected_values(t);
  return t;
}

Trial catalog_trial(int index, std::uint64_t seed, const HarnessSetup& setup, const Threshold& term,
                    double multiple) {
  Rng rng = trial_rng(index, seed);
  Trial t = new_trial(index, TrialKind::catalog, seed, rng, setup);
  conceal(t, term, multiple, rng);
  settle_expected_values(t);
  return t;
}

Trial uncatalogued_trial(int index, std::uint64_t seed, const HarnessSetup& setup,
                         const std::string& id) {
  Rng rng = trial_rng(index, seed);
  Trial t = new_trial(index, TrialKind::uncatalogued, seed, rng, setup);
  conceal_uncatalogued(t, id, rng, setup);
  settle_expected_values(t);
  return t;
}

Recording record(const Trial& trial, const HarnessSetup& setup) {
  return generate_recording(trial.truth, setup.run, trial.generator_seed);
}

GaussMarkovNoise specified_wander() { return {Vec3::Constant(5 * kUg), 300}; }

Outcome diagnose_trial(const Trial& trial, const Recording& rec, bool without_specification) {
  DiagnoseOptions options;
  if (trial.kind == TrialKind::coloured && !without_specification)
    options.specified_wander = specified_wander();
  const Diagnosis d = diagnose_recording(rec, options);
  Outcome o;
  o.verdict = d.verdict;
  o.summary = d.summary;
  for (const Finding& f : d.findings)
    if (!is_noise_finding(f)) o.findings.push_back(f);
  switch (trial.kind) {
    case TrialKind::white:
    case TrialKind::coloured:
      o.false_finding = !o.findings.empty() || o.verdict == "ambiguous";
      o.right = o.verdict == "consistent" && o.findings.empty();
      break;
    case TrialKind::uncatalogued:
      o.right = o.verdict == "unexplained";
      break;
    case TrialKind::catalog:
    case TrialKind::pair:
      score_catalog(trial, o);
      break;
  }
  return o;
}

bool finds(const Outcome& outcome, const ConcealedEffect& effect) {
  return std::any_of(outcome.findings.begin(), outcome.findings.end(),
                     [&effect](const Finding& f) { return same_effect(f, effect); });
}

PowerPoint power_trial(const Trial& trial, const HarnessSetup& setup) {
  const Recording rec = record(trial, setup);
  return {finds(diagnose_trial(trial, rec), trial.drawn.front().effect),
          ideal_power(trial, rec, setup)};
}

}  // namespace standcal::bench
