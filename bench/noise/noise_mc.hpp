#pragma once
// Monte Carlo of the estimators' sigmas under coloured noise (issue 21, docs/calibration.md
// "Noise model"): seeded simulated runs of one programme with white noise and with
// Gauss-Markov bias wander, each fitted by the full-vector, the invariant and the
// attitude-free norm estimator (the same recording without its angles), and
// (estimate - truth) / sigma collected per unit parameter. Honest sigmas give z-variance 1.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "calib/noise_model.hpp"
#include "calib/parameters.hpp"
#include "calib/programs.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording.hpp"

namespace standcal::noise_mc {

struct Scenario {
  std::string name;
  double wander_per_dwell_error = 0;  // Gauss-Markov sigma / white error of one dwell mean
  double tau_s = 300;
  // Above tau_s: each run draws its own correlation time, log-uniformly from tau_s to this
  // (units whose tau nobody measured, of which one run cannot tell which it is).
  double tau_max_s = 0;
  bool tau_drawn() const { return tau_max_s > tau_s; }
};

struct Setup {
  Program program;
  double dwell_s = 10;
  double sample_rate_hz = 25;
  int runs = 1000;
  std::uint64_t first_seed = 1;
  int threads = 2;
  double weighting_lr = FitNoiseOptions{}.weighting_lr;  // the default fit's
  // "tau given" weights with this multiple of the simulated correlation time: how well the
  // unit's tau must be known (a long static recording's Allan fit pins it within ~2x).
  double tau_given_factor = 1;
  // ... or the range of correlation times from that / this to that x this (1: one value), as
  // `standcal noise` gives it from a static recording.
  double tau_given_range = 1;
  // Rows "unit given": the fit told the unit's wander, its size and correlation time, as
  // `--bias-instability-ug Q --bias-instability-tau-s T` tell it (from a long static
  // recording's Allan fit, `standcal noise`, or the data sheet). It still estimates the
  // wander from the run and weights with that where the run shows one; the given size is
  // what it weights with where the run does not. The size given is this multiple of the
  // simulated one's; the correlation time as "tau given" (factor, range).
  bool unit_given_rows = false;
  double size_given_factor = 1;
  // Above 0: the "unit given" rows are told instead what `standcal noise` says of a static
  // recording of the same unit this many hours long (its own seeded recording per run, at
  // kStaticRecordingRateHz): the largest axis's q and the correlation times it allows, where
  // it sees a wander, pins its time and describes the curves (the advice it then prints);
  // otherwise no wander, and those runs' fits are given the static recording itself
  // (`--unit-static-recording`, as standcal noise then advises): where its curves show no
  // wander, they bound the wander the fits' sigmas allow for (the stand fits' since 2026-12-07).
  double static_hours = 0;
  // Above 0: the programme's warm-up (Program::warmup_s): the first position held this many
  // hours before its dwell, recorded but out of its mean, whose Allan curves the "estimated"
  // and "tau given" rows take as the unit's wander where they pin one, and as a bound on it
  // where they show none (take_recording_wander_or_bound), as standcal fit and standcald do.
  double warmup_hours = 0;
  // Above 0: a bias settling after power-on, warmup_transient_ug * exp(-t / tau) on every axis
  // from the run's first sample (a warm-up that still drifts thermally, which neither the
  // calibration model nor a Gauss-Markov wander describes).
  double warmup_transient_ug = 0;
  double warmup_transient_tau_s = 1200;
  double specified_exceeded_p = FitNoiseOptions{}.specified_exceeded_p;
  // The unit's output filter (NoiseModel::output_filter_tau_s): samples correlated within a
  // dwell, which sigma / sqrt(n) does not see. 0: independent samples.
  double output_filter_tau_s = 0;
};

// z statistics of one estimator with one weighting in one scenario.
struct ZStats {
  std::string estimator;  // "full" | "joint" | "norm" (the recording without its angles)
  // "estimated" (the default) | "tau given" | "unit given" (Setup) | "true" (the simulated
  // wander, given and used whatever the run shows) | "white"
  std::string weighting;
  std::array<double, kUnitParameterCount> z2_mean{};  // mean z^2: the z-variance about truth
  std::array<double, kUnitParameterCount> z_mean{};
  std::array<double, kUnitParameterCount> coverage95{};  // share of runs with |z| <= 1.96
  std::array<int, kUnitParameterCount> n{};
  // Per group of unit parameters (biases, scale factors, gammas), one entry per run and
  // parameter: its sigma over the sigma the same estimator gives on the same run weighted as
  // white noise. What weighting for a wander the run may not have costs (under white noise),
  // or how far it widens (under wander).
  std::array<std::vector<double>, 3> sigma_over_white;
  // The biases' z^2 summed and counted apart for the runs this fit weighted as white noise
  // ([0]) and for a wander ([1]): where the excess of an estimated noise model lies.
  std::array<std::array<double, 3>, 2> bias_z2_by_weighting{};
  std::array<int, 2> runs_by_weighting{};
  // The wander's size the fit weighted with over the simulated one, (q / q_true)^2 summed
  // over runs and axes (a wander simulated), and how many: how far its estimate is biased.
  double wander_q2_ratio_sum = 0;
  int wander_q2_ratio_n = 0;
  int wander_significant = 0;  // runs whose fit found the wander significant
  int unit_given = 0;        // "unit given" runs given a wander: figures, or the static recording's
  int recording_wander = 0;  // runs whose fit took the recording's own (warmup_hours)
  int recording_tau_floor = 0;  // ... or the floor its curves put under the correlation time
  int runs = 0;
  int failed = 0;  // runs whose fit threw
};

struct ScenarioResult {
  Scenario scenario;
  double white_dwell_error_ug = 0;
  // Runs whose dwells' Allan curves showed the samples correlated, so that the averages'
  // standard errors were widened (calib/allan.hpp, SampleCorrelation).
  int samples_correlated = 0;
  std::vector<ZStats> stats;
};

inline constexpr double kStaticRecordingRateHz = 10;

ScenarioResult run_scenario(const Setup& setup, const Scenario& scenario);

// The four scenarios of issue 21: white, and wander at 1x, 3x and 10x the dwell error.
std::vector<Scenario> issue21_scenarios();

// The settling of Setup::warmup_transient_ug (its size and warmup_transient_tau_s), added to
// the unit's outputs from the recording's first sample (a bias: the same on each axis whatever
// the orientation).
void add_warmup_transient(Recording& rec, const Setup& setup);

// A static recording's three axes (ug, simulate_static_gauss_markov's) as the raw input
// `standcal fit --unit-static-recording` reads: the unit level (z up) in m/s^2, as raw_input_of
// gives a calibration recording, sampled at rate_hz.
std::shared_ptr<const RawInput> static_raw_input(const std::vector<std::vector<double>>& axes_ug,
                                                 double rate_hz, double g_mps2);

}  // namespace standcal::noise_mc
