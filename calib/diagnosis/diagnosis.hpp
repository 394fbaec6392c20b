#pragma once
// Model-mismatch diagnosis (issue 6): fit the baseline model, test whether its residuals
// are noise, locate where they are not, test every candidate of the catalog of missing
// physics (../shared/docs/model.md) with the parametrisations it fixes, keep a term only
// if an information criterion AND a leave-positions-out prediction check both want it,
// refit, and say what was found in words and as a model the simulator reproduces.
// The public API of the calib/diagnosis room (docs/diagnosis.md, "Where the code is").
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/noise_model.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"

namespace standcal {

// The Allan floor (bias instability) of the navigation-grade unit the catalog's plausible
// sizes describe (model.md: "a few ug").
inline constexpr double kNavigationGradeAllanFloor_ug = 5;

struct DiagnoseOptions {
  // A term must lower chi2 by this much (4 sigma for one parameter: with ~50 candidates
  // tested per round the chance of a false finding stays below 1 %), besides BIC.
  double significance_chi2 = 16;
  // Two candidates whose chi2 gains differ by less than this (3 sigma) cannot be told apart.
  double ambiguity_chi2 = 9;
  // Residuals count as consistent with noise when P(chi2 > observed) exceeds this.
  double consistency_p = 1e-3;
  // A candidate's signature must keep this fraction of its size after the baseline
  // parameters have absorbed what they can; otherwise the programme cannot test it.
  double min_unabsorbed_fraction = 0.05;
  int max_terms = 4;
  // Settling-transient time constants searched on the raw samples (s).
  std::vector<double> settling_tau_grid_s{1, 2, 4, 8, 15, 30};
  // A mounting misalignment counts as large (mounting_misalignment_large) when it exceeds
  // this by 4 sigma: at 5 arcmin the invariant method's silent scale-factor bias
  // (1 - cos psi, model.md) reaches 1 ppm.
  double mounting_tolerance_arcmin = 5;
  // Where the stand can go: every proposed position lies inside these ranges.
  StandLimits limits;
  // Bias wander (model.md bias_instability) is believed when the Gauss-Markov noise model
  // raises the restricted log-likelihood by this much (2 delta log L; chi2 with four
  // parameters at P = 1e-3). Infinity: always test against white noise.
  double wander_lr_threshold = 18.5;
  // The largest bias wander (Gauss-Markov standard deviation) the unit's class can have: a
  // navigation-grade quartz unit's bias instability is a few ug. A larger "wander" is an
  // event (a jump, a knock, an oscillation), not noise, and is left for the checks to find.
  double max_bias_instability_ug = 6;
  // The unit's bias wander as known before this run: its specification, or `standcal noise`
  // on a long static recording. One short run often cannot tell a few ug of wander from a
  // drift or a temperature coefficient (docs/diagnosis.md, "Noise"); when it does not show
  // the wander itself, the terms are tested against this. White: nothing known.
  GaussMarkovNoise specified_wander;
  // The unit's correlation time when known (one value or a range: `standcal noise` of a long
  // static recording): the wander is then estimated at it, as the fits do (FitNoiseOptions::
  // known_tau), rather than over the default grid that one run cannot choose from.
  std::optional<KnownTau> known_tau;
  // Where those came from when not from the operator (FitNoiseOptions::specified_from): the
  // recording's header or its own long dwell, which diagnose_recording takes where nothing is
  // given, as the fits do (take_unit_wander).
  std::string specified_wander_from;
  // The floor under the wander's correlation time that the unit's static recording's Allan
  // curves put where they see a wander they do not pin (0: they put none); nullopt where no
  // static recording was given, and the one the recording's header carries from standcald's is
  // taken. Where nothing pins a wander, the diagnosis tests the terms under the higher of it and
  // the recording's own long dwell's floor, as the fits weigh (take_unit_wander).
  std::optional<double> unit_static_tau_floor_s;
  // Before `explained` or `consistent`: the residuals must pass the whiteness tests at this
  // family-wise false-alarm rate, each chosen term must agree between the two halves of the
  // run within this many sigma, and no found value may exceed this many times its
  // catalog's typical_max.
  double whiteness_family_alpha = 1e-3;
  double half_stability_z = 4;
  double implausible_factor = 10;
  // The recording's directions are measured, not commanded (a recording without angles,
  // calibrated by the norm fit): the residual model is |f| - g, which sees only the unit's
  // physics, never the stand's (no angle sensor, no levelling, no approach direction).
  bool attitude_free = false;
  // The catalog's plausible sizes (typical_max) are a navigation-grade unit's, whose bias
  // instability is a few ug; a coarser unit's K2, drift or cross-coupling are larger in
  // proportion. Multiplies every typical_max (the attitude-free diagnosis sets it from the
  // recording's Allan floor against kNavigationGradeAllanFloor_ug).
  double plausible_size_factor = 1;
  // When given, one per position: the standard error of each dwell mean (g per axis), in
  // place of sigma / sqrt(n) where it is larger. A caller that knows the noise within a
  // dwell is not white (the Allan deviation of an attitude-free recording) passes it here.
  std::vector<Vec3> dwell_standard_error_g;

  // The wander the unit's static recording pinned (take_static_recording_pinned_wander: its
  // use.wander where use.gave is "wander"), as the unit's: the terms are tested against it.
  void give_static_recording_wander(const GivenWander& w);
};

// A trend of the baseline's normalised residuals against one variable, per axis.
struct StructureTest {
  std::string axis;     // "x", "y", "z" (full vector) or "L" (invariant projection)
  std::string against;  // "time", "temperature", "approach", "angle_u2", "angle_u3"
  double z = 0;         // trend in sigma units (about N(0,1) for pure noise)
};

// One catalog candidate tested against the current model.
struct CandidateTest {
  std::string effect;  // catalog id
  std::string axis;    // "x", "y", "z" or ordered pair "zx"
  std::string unit;    // report unit
  bool testable = true;
  std::string reason;  // why not testable
  double value = 0, sigma = 0;
  double delta_chi2 = 0;
  double delta_bic = 0;   // BIC(before) - BIC(after): positive favours the term
  double press_gain = 0;  // held-out chi2 (leave-one-position-out) before - after
  double tau_s = 0;       // settling transient only
  int params = 1;         // parameters of the term (angle_sensor_error: 2, amplitude and phase)
  double phase_deg = 0;   // angle_sensor_error only: true - read = value * sin(alpha + phase)
};

struct Finding {
  std::string effect, axis, unit;
  double value = 0, sigma = 0, tau_s = 0;
  double delta_chi2 = 0;
  double chi2_dof_before = 0, chi2_dof_after = 0;
  std::string absorbed_into;  // e.g. "bias_z (+23.1 ug)"
  std::string explanation;
  double phase_deg = 0;  // angle_sensor_error only
};

struct ProposedPosition {
  double alpha1_deg = 0, alpha2_deg = 0;
  double predicted_difference_sigma = 0;  // ambiguous: between the two rivals; else 0
  std::string why;
};

// Normalised residuals (residual / standard error) of one position, before and after.
struct ResidualRow {
  int pos = 0;
  double alpha1_deg = 0, alpha2_deg = 0, t_mid_s = 0, temp_c = 0;
  int approach = 1;
  std::vector<double> before, after;  // 3 (full) or 1 (invariant) components
};

// The noise the tests were made against (calib/noise_model.hpp). A noise finding, never a
// deterministic term: bias_instability is true when the dwell means wander beyond their
// white-noise errors, and every chi2 and sigma then comes from generalised least squares.
// Honesty outside the catalog (docs/diagnosis.md, "Checks before explained").
struct WhitenessCheck {
  std::string axis, against, test;  // "x", "time", "serial" | "step"
  double statistic = 0, p = 1;
  std::vector<int> positions;  // where the pattern is strongest
  double t_from_s = 0, t_to_s = 0;
};
struct StabilityCheck {
  std::string effect, axis, unit;
  double value = 0, sigma = 0;  // whole run
  // The two halves: the first and second half of the run in time, or, for a recording
  // without angles, its even and odd intervals (whose orientations do not follow a plan).
  std::string halves = "time";  // "time" | "alternate"
  double first = 0, first_sigma = 0, second = 0, second_sigma = 0;
  double z = 0;
  bool stable = true;
};
struct HonestyChecks {
  bool made = false;   // false: the verdict did not need them (or no redundancy)
  bool passed = true;  // residuals white, every term stable and plausible
  double family_alpha = 0;
  std::vector<WhitenessCheck> whiteness;    // every test, in the order made
  int worst = -1;                           // index of the smallest p
  std::vector<StabilityCheck> stability;    // one per chosen term
  std::vector<std::string> implausible;     // found values beyond their kind's plausible size
  std::vector<std::string> not_explaining;  // catalog candidates tried that do not explain it
};

struct Diagnosis {
  std::string
      verdict;         // consistent | explained | unexplained | insufficient_redundancy | ambiguous
  std::string method;  // "full" (full-vector) or "joint" (invariant)
  std::string source;
  FitResult baseline;
  FitResult final_fit;
  double baseline_p = 1, final_p = 1;  // P(chi2 > observed)
  double final_chi2_dof = 0;
  std::vector<StructureTest> structure;
  std::vector<std::string> located;       // where the mismatch is, in words
  std::vector<CandidateTest> candidates;  // the first round: every candidate vs the baseline
  std::vector<Finding> findings;          // most significant first
  std::vector<std::string> not_tested;    // catalog ids not tested, with why
  std::vector<ProposedPosition> proposed_positions;
  std::vector<ResidualRow> residuals;
  std::vector<std::string> summary;  // the diagnosis in sentences, with numbers
  TruthModel model;                  // augmented model for `standcal simulate --model`
  NoiseFinding noise;
  // Whose floor under the wander's correlation time the terms were offered
  // (kWanderFromStaticRecording, kWanderFromRecording; "" none), and what came of it: "kept"
  // (the wander estimated under it, which the terms are tested against), "refused" (estimated
  // under it, but beyond the class bound: not taken as noise, noise.how says so), "set_aside"
  // (the revisits do not show the wander at those times) or "untested" (the diagnosis could not
  // check the model: its summary says why).
  std::string tau_floor_from;
  std::string tau_floor_outcome;
  HonestyChecks checks;
};

Diagnosis diagnose_recording(const Recording& rec, const DiagnoseOptions& options = {});

// A recording without angles, calibrated by the norm fit (norm_calibration.hpp): its static
// intervals as the dwells of a recording in calibrated m/s^2 (the measured directions as
// angles, each interval's start as its arrival), diagnosed with the |f| - g residual model,
// each mean's error from the recording's Allan deviation, and the bias wander between
// intervals that the norm fit estimated as the noise the terms must stand out from.
// Throws CannotFit for a means table (no samples to test a settling transient or
// whiteness on).
Recording calibrated_recording(const RawInput& input, const NormCalibration& calibration);
Diagnosis diagnose_without_angles(const RawInput& input, const NormCalibration& calibration,
                                  DiagnoseOptions options = {});

// The discrimination threshold of one candidate on a programme: the smallest size (report
// unit) at which it stands out at 3 sigma both from the noise and from its nearest
// competing candidate, i.e. 3 / s_min, where s_min is the smallest singular value of the
// candidate's whitened columns after projecting out the baseline parameters AND the
// competitor's columns (for one column: 3 / (|P c| sqrt(1 - rho^2))). Settling transients:
// 3 sigma of the amplitude fitted on the raw samples at that tau. Large mounting: the
// tolerance + 3 sigma of the fitted mounting angle. Infinite when a competitor is collinear.
struct DiscriminationThreshold {
  std::string effect, axis, unit;
  double tau_s = 0;      // settling_transient: the time constant it is for
  double threshold = 0;  // report unit
  std::string nearest;   // "effect axis" of the competitor that sets it, or "noise"
};
// Thresholds of every testable candidate for the programme, timing, noise and temperature
// profile of `reference` (an effect-free recording of it; only its design and standard
// errors are used, not its residuals).
std::vector<DiscriminationThreshold> discrimination_thresholds(const Recording& reference,
                                                               const DiagnoseOptions& options = {});

// The diagnostic programme `diagnostic32` (docs/diagnosis.md) the blind tests and the
// harness use: 16 distinct positions on mount x, spread over the sphere with intermediate
// angles on every axis, visited forward and then in reverse (both approach directions, two
// times each). 32 positions; redundancy for every catalog candidate.
Program diagnostic32();

// The mounting misalignment (rad, about instrument x, y, z) a full-vector fit of one mount-x
// programme estimates for a simulated truth: psi composed with what it cannot be told apart
// from, the unit's antisymmetric non-orthogonality and (about x, the inner axis) the
// inner-axis angle zero (model.md). Test and bench helper to compare findings with truths.
Vec3 identifiable_mounting_rad(const TruthModel& truth);
nlohmann::json diagnose_to_json(const Diagnosis& d);

}  // namespace standcal
