#pragma once
// Bias wander between dwells (model.md `bias_instability`): a Gauss-Markov bias per
// accelerometer axis, b_a(t) with variance q_a^2 and correlation exp(-|dt| / tau), under
// the white noise that each dwell mean's standard error describes. Wander correlated over
// minutes does not average down inside a 10 s dwell nor across positions, so the means of
// dwells close in time share it; their covariance is
//   C(r, s) = sigma_r^2 delta_rs + sum_a P_r[a] P_s[a] q_a^2 k(w_r, w_s)
// where row r is one projection P_r of one dwell mean (e_a for a full-vector component,
// u for the invariant projection) and k the correlation of the wander's means over the two
// dwells' windows w (gauss_markov_window_correlation): exp(-|t_r - t_s| / tau) for values at
// instants, less between the means of neighbouring dwells. Taking a mean as the wander's
// value at the dwell's mid-time overstates how much consecutive means differ (by 13 % for
// 10 s dwells 30 s apart at tau = 300 s), and the wander's size fitted to them came out too
// small by about as much (docs/calibration.md, "Noise model").
//
// The wander and its mean over the current window are a 6-state linear system, so a Kalman
// filter over the rows in time order turns any column into its innovations: exactly
// C^{-1/2} (the Cholesky factor's inverse), in O(rows) rather than O(rows^3). The diagnosis
// and the estimators work on that decorrelated problem (generalised least squares) and estimate q
// and tau from it by restricted maximum likelihood (REML), which does not count the fitted
// parameters' share of the residual as noise.
#include <Eigen/Dense>
#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/allan.hpp"
#include "calib/model.hpp"
#include "calib/position_average.hpp"

namespace standcal {

// What the noise model needs to know of one row of a whitened linear problem.
struct NoiseRow {
  double t_s = 0;                  // mid-time of the dwell
  Vec3 projection = Vec3::Zero();  // which combination of the three axes the row measures
  double sigma_g = 0;              // white standard error of the row (g): its whitening
  double window_s = 0;  // the span the row's mean is taken over, centred on t_s (0: an instant)
};

struct GaussMarkovNoise {
  Vec3 q_g = Vec3::Zero();  // stationary standard deviation of the wander, per axis (g)
  double tau_s = 0;         // correlation time
  bool white() const { return q_g.isZero(); }
};

// The correlation of a Gauss-Markov process's means over two windows of time (start, length;
// a length of 0 is an instant): the variance of one window's mean 2 (x - 1 + e^-x) / x^2
// (x = length / tau), and between disjoint windows e^(-gap / tau) times (1 - e^-x) / x for
// each. Windows that partly overlap are taken as adjoining.
double gauss_markov_window_correlation(double a_start_s, double a_length_s, double b_start_s,
                                       double b_length_s, double tau_s);

// The row of one dwell mean's projection on `projection`, whitened by sigma_g: its time the
// dwell's mid-time, its window the dwell's span.
NoiseRow noise_row(const PositionAverage& position, const Vec3& projection, double sigma_g);

// The rows of the two estimators' problems, in position order, whitened by the standard
// error each position's mean carries: full-vector, three per position (x, y, z); invariant,
// one per position, the projection on the commanded up-vector u. A row's time is its
// dwell's mid-time, its window the dwell's span.
std::vector<NoiseRow> full_vector_noise_rows(const std::vector<PositionAverage>& positions,
                                             double sigma_floor_g);
std::vector<NoiseRow> invariant_noise_rows(const std::vector<PositionAverage>& positions,
                                           const std::vector<double>& sigma_g);

// The rows' covariance C itself (rows x rows, in g^2), for a linear estimate's L C L^T.
Eigen::MatrixXd row_covariance(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise);

// C^{-1/2} M for the rows' covariance under `noise`, where M's rows are already whitened
// by sigma (row r divided by sigma_r): returns the innovations of each column, normalised
// to unit variance. log_det_out, when given, receives log |C_w| (C in whitened units).
Eigen::MatrixXd decorrelate(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise,
                            const Eigen::MatrixXd& whitened, double* log_det_out = nullptr);

struct PlausibleNoise {
  GaussMarkovNoise noise;
  double weight = 1;  // likelihood relative to the best model's
};

// The wander's free scales and how well the run pins them: each scale multiplies the q of
// a set of axes (the q common to the axes that share it, or one axis's own), and
// `information` is the restricted likelihood's curvature in u_k = log s_k^2 at the optimum
// (-d^2 log L / du_k du_l). var(u) = information^-1; one scale's variance is worth
// 2 * information degrees of freedom (a chi-square's).
struct WanderScales {
  std::vector<Vec3> axes;  // per scale: 1 on the axes it multiplies, 0 elsewhere
  Eigen::MatrixXd information;
  bool empty() const { return axes.empty(); }
};

struct NoiseEstimate {
  GaussMarkovNoise noise;   // white (q = 0) unless the wander is significant
  GaussMarkovNoise best;    // the REML optimum, significant or not
  double lr = 0;            // 2 (restricted log-likelihood(best) - log-likelihood(white))
  double lr_threshold = 0;  // lr needed to call the wander significant
  bool significant = false;
  int parameters = 0;  // of best: its q (a common one, and each axis's own) and tau from a grid
  std::string how;     // how it was obtained, in words
  // How well the run pins the wander's size at best (empty when best is white): the common
  // q's scale and each departed axis's own, with their information. An axis whose q the run
  // pins from its own rows alone is pinned far worse than the common q.
  WanderScales scales;
  // One run pins the correlation time poorly, and the biases' sigmas depend on it: the
  // optimum at each tau of the grid within plausible_lr of the best, with its likelihood
  // relative to the best's.
  std::vector<PlausibleNoise> plausible;
  // The axes that keep the specified q where the run departs upwards from it
  // (run_agrees_with_specified): the run's own is smaller there.
  std::array<bool, 3> axes_specified{};
};

struct NoiseEstimateOptions {
  std::vector<double> tau_grid_s{60, 150, 300, 600, 1200};
  // 2 delta log L from the best within which another tau counts (its weight exp(-lr/2) is
  // then above 0.7 %).
  double plausible_lr = 10;
  // 2 delta log L of the wander model over white noise for it to be believed: chi2 with
  // four parameters (three q, one tau) at P = 1e-3 is 18.5.
  double lr_threshold = 18.5;
  // 2 delta log L by which one axis's own q (or none on that axis) must beat the wander
  // common to the three axes for the axis to get it: chi2 with one parameter at P = 0.01.
  // A per-axis q from a few dozen rows is poorly pinned, and a q that comes out low makes
  // that axis's bias sigma too small (docs/calibration.md, "Noise model").
  double axis_lr = 6.63;
  // The same for an axis's q below the common one (or none): chi2 with one parameter at
  // P = 1e-3. A q set too low makes that axis's bias sigma too small, one set too high only
  // conservative; and a norm fit's axis whose rows pin its wander poorly went to none under
  // a 10x wander in 3 of 400 runs at the bar above, its bias then 5.6-12 sigma off (the bias's
  // z-variance 1.88 where 1.1 without those runs).
  double axis_quieter_lr = 10.83;
};

// REML estimate of the wander for the linear model y = X beta + e (both already whitened
// by sigma; X's column space is the fitted model). For each tau of the grid, a q common to
// the three axes by golden section on log q, then each axis's own q (or none) where its
// rows demand it (options.axis_lr; axis_quieter_lr for a q below the common one).
NoiseEstimate estimate_bias_wander(const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X,
                                   const Eigen::VectorXd& y,
                                   const NoiseEstimateOptions& options = {});

// The restricted log-likelihood (up to a constant) of y = X beta + e under `noise`: how
// well another noise model is supported by the same rows (2 x the difference is a
// likelihood-ratio statistic).
double restricted_log_likelihood(const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X,
                                 const Eigen::VectorXd& y, const GaussMarkovNoise& noise);

// The wanders common to the three axes, on the estimator's grid of sizes (3 % to 30x the
// median row's sigma, log-spaced, and none) at each correlation time of tau_grid_s, whose
// restricted likelihood is within options.plausible_lr (2 delta log L) of the best of them:
// each with its likelihood relative to that best. Where the run does not pin the wander's
// size, its estimate's curvature (WanderScales) says nothing of how large a wander it allows.
// `curves_ug`, where given: the recording's own Allan curves (in ug), whose likelihood of each
// wander multiplies the rows' (independent data: the samples within the stretches, where the
// rows are their means).
std::vector<PlausibleNoise> plausible_wander_sizes(
    const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
    const NoiseEstimateOptions& options, const std::optional<WanderCurves>& curves_ug = {});

// How an estimator weights its dwell means (docs/calibration.md, "Noise model").
// sqrt(nu / (nu - 2)), the standard deviation of Student's t with nu degrees of freedom
// (nu floored at 2.5, where it runs away; 1 for infinite nu): what an estimated noise
// model's sigma is widened by, so that it has z-variance 1.
double student_t_inflation(double nu);

// A time as the reports print it and the command line takes it back: whole seconds from
// 10 s up, three digits below, no exponent ("1200", "0.4").
std::string seconds_text(double s);

// The unit's correlation time as known before a run: one value, or the range a static
// recording's Allan curves allow it (`standcal noise`), over which the run's likelihood then
// weighs (kKnownTauRangePoints correlation times, log-spaced).
struct KnownTau {
  double min_s = 0, max_s = 0;  // equal: one value
  // Known only from below: Allan curves that see a wander they do not pin put it at min_s or
  // longer, and max_s is the longest the fits model (take_recording_tau_floor).
  bool open_above = false;
  bool range() const { return max_s > min_s; }
  double centre_s() const;  // the log-middle, sqrt(min max): one wander to weight with
  std::vector<double> grid_s() const;
  std::string seconds() const;  // "300 s" / "150-600 s"
  std::string words() const;    // "the given correlation time 300 s" / "... times 150-600 s"
};
inline constexpr int kKnownTauRangePoints = 5;

// FitNoiseOptions::specified_from (and NoiseFinding::unit_wander_from) of a wander the
// recording's own Allan curves gave; also FitNoiseOptions::wander_curves_from of its curves.
inline constexpr const char* kWanderFromRecording = "recording";

// FitNoiseOptions::specified_from of the unit's wander a recording's header gives (the one its
// run was fitted with: RecordedUnitWander).
inline constexpr const char* kWanderFromHeader = "header";

// FitNoiseOptions::specified_from and wander_curves_from of what a long static recording of
// the unit, apart from the calibration's, gave: the wander its Allan curves pin, the floor they
// put under its correlation time, or the curves themselves where they show none
// (NormCalibrationOptions::unit_static_recording; standcald's, whose runs' headers carry its
// curves: take_header_static_curves).
inline constexpr const char* kWanderFromStaticRecording = "static_recording";

struct FitNoiseOptions {
  enum class Mode {
    white,      // each mean independent, with the standard error sigma/sqrt(n) of its dwell
    estimate,   // bias wander estimated from this run (REML on the white fit's residuals) and
                // used when significant; otherwise `specified` when given, else white
    specified,  // `specified`, whatever the run shows
  };
  Mode mode = Mode::estimate;
  // estimate: weight for the REML optimum once it beats white noise by this much in
  // 2 delta log L, significant or not. Weighting for a wander that is not there costs a
  // little precision; ignoring one that is makes every sigma too small.
  double weighting_lr = 1.0;
  GaussMarkovNoise specified;  // the unit's known bias instability (data sheet, earlier runs)
  // estimate, with a wander specified and its correlation time known (known_tau): a wander
  // the run shows is weighted as the specified one unless the run departs from it (its REML
  // optimum against the specified wander: 2 delta log L, chi-square with the optimum's
  // parameters) at P below specified_departure_p, or below specified_exceeded_p where the
  // run's wander is the larger on some axis. The specified wander comes from more data than
  // one run, and the run's own estimate, taken where it is a finding, is one selected for
  // being large and widens the sigmas for its own uncertainty: weighted with it, a 1x
  // wander's biases came out conservative (0.81-0.83 in z-variance, full fit). The laxer bar
  // upwards because a specified wander too small is the error that makes sigmas too small: a
  // size given half the true one left a 3x wander's biases at 1.10-1.17 (full fit) at 0.01,
  // 1.01-1.08 at 0.05, costing nothing where it is right (docs/calibration.md, "The unit
  // given").
  double specified_departure_p = 0.01;
  double specified_exceeded_p = 0.05;
  // estimate: the unit's correlation time, known (a long static recording's Allan curves,
  // `standcal noise`; the data sheet): the run then estimates only the wander's size. One
  // run of a quarter of an hour cannot tell a wander of 60 s from one of 1200 s, and the
  // biases' sigmas depend on it several-fold (docs/calibration.md, "Noise model").
  std::optional<KnownTau> known_tau;
  // Where `specified` and known_tau came from: "" (the operator: `--bias-instability-ug`,
  // standcald's configuration), kWanderFromHeader (the recording's header: what its run was
  // made with, take_header_wander), kWanderFromRecording (its long dwell,
  // take_recording_wander) or kWanderFromStaticRecording (the unit's static recording).
  std::string specified_from;
  NoiseEstimateOptions estimate;
  // estimate, invariant fit: estimate the wander from the full vector of the dwell means
  // (three rows per position, where the full-vector model fits the programme) rather than
  // from the invariant projection alone. Off where the attitudes are not the stand's but
  // read off the means themselves (the norm fit): the full vector's residuals are then
  // empty across the measured direction and would hide the wander.
  bool estimate_from_full_vector = true;
  // estimate, no size of the unit's wander given (its correlation time may be), the run's
  // wander no finding: widen the sigmas to at least their average over the wander's sizes and
  // correlation times the run allows (FitNoiseChoice::plausible_sizes). For fits whose rows
  // cannot tell white noise from a wander as large as a dwell's error (the norm fit: one row
  // per interval), and for any fit given curves that bound the wander (below).
  bool average_over_wander_sizes = false;
  // average_over_wander_sizes: Allan curves (ug) that show no wander (take_wander_curves: the
  // recording's own, or the unit's static recording's), which weigh each size beside the rows:
  // a long static stretch that shows no wander excludes one its curves would show (an hour's
  // warm-up, a long first interval, a static recording), and narrows the sigmas.
  std::optional<WanderCurves> wander_curves_ug;
  // Whose curves those are: kWanderFromRecording (this recording's own) or
  // kWanderFromStaticRecording (the unit's static recording).
  std::string wander_curves_from = kWanderFromRecording;
};

// The unit's bias wander as given (a data sheet, `standcal noise` of a static recording,
// `--bias-instability-*`, standcald's unit.bias_instability_*): its size and, where known,
// its correlation time, one value or a range. One spelling for every place that gives it.
struct GivenWander {
  // Steady-state sigma per axis, the largest axis's where size_axes_ug is given; 0: no size
  // given.
  double size_ug = 0;
  double tau_s = 300;  // the correlation time weighed at where none is known
  std::optional<KnownTau> known_tau;
  // Each axis's, where Allan curves pin one per axis (a unit's axes wander each its own: the
  // largest on every axis overstates the others'); zero: size_ug on each.
  Vec3 size_axes_ug = Vec3::Zero();
  bool given() const { return size_ug > 0 || known_tau.has_value(); }
  Vec3 axes_ug() const;  // each axis's size
  // The wander to weigh with: at a range's log-middle, where the fits then average the biases'
  // variance over the range itself.
  GaussMarkovNoise specified() const;
  // Into the fits' options (specified, known_tau, specified_from = `from`).
  void give_to(FitNoiseOptions& options, const std::string& from = "") const;
};

// The header keys of a run's recording that carry `w` (replacing any), and its
// RecordedUnitWander; and back. A tau_s without known_tau is not kept: nothing gives one but
// the default, which given_wander_of restores.
void set_unit_wander_header(Recording& header, const GivenWander& w);
GivenWander given_wander_of(const RecordedUnitWander& recorded);
// The wander Allan curves pin (AllanFinding::wander), as the unit's: its size and the
// correlation times the curves allow.
GivenWander given_wander_of(const WanderToGive& pinned);

// Where the fit estimates the noise and nothing of the unit's wander is given, the wander the
// recording's header says its run was made with (standcald's unit.bias_instability_*, which
// the run's own fits weighed with): later fits of the run (`standcal fit`, `run result`,
// `certificate`, `records import`) then weigh as the run did. Returns whether it took one.
bool take_header_wander(FitNoiseOptions& options, const Recording& rec);
// Whether `rec`'s header says nothing of the unit's wander its run was begun with: none of
// unit_bias_instability_* (_ug is 0 where none was configured: set_unit_wander_header writes it
// always; a correlation time alone is something), its static recording's words, curves or
// floor. Only a run begun before standcald's headers carried them: standcald's end fit, drift
// rule and run.diagnose of such a run take the configured wander, as they did then. Every other
// run is weighed as its header says, even none, as every later fit of its recording is,
// whatever the configuration says since.
bool header_silent_on_unit_wander(const Recording& rec);

// The unit's wander for `rec`, where none is given: its header's, else its own long dwell's
// (take_recording_wander), else the higher floor under the correlation time that the unit's
// static recording's curves (`static_tau_floor_s`: of the one given, 0 where its curves put
// none; nullopt where none was given: the one rec's header carries from standcald's) and its own
// long dwell put (take_higher_tau_floor). Returns whether it took one. The diagnosis's rule (it
// weighs no bound on a wander); the fits also take a long dwell's bound where it pins none
// (take_recording_wander_or_bound, take_unit_wander_with_static_recording).
bool take_unit_wander(FitNoiseOptions& options, const Recording& rec,
                      const std::optional<AllanFinding>& allan,
                      std::optional<double> static_tau_floor_s);

// Where the fit estimates the noise and nothing of the unit's wander is given (no size, no
// correlation time), takes the wander the recording's own dwells' Allan curves pin as the
// unit's given one (specified, known_tau as the range the curves allow, specified_from
// kWanderFromRecording): a dwell long enough to show the wander turn over (about 100 x its
// correlation time: an hour's warm-up for a wander of a few tens of seconds, several for
// 300 s) says what one quarter-hour of positions cannot. Only where the curves reach the Allan
// peak of the longest correlation time they allow (curves_show_turnover) and that time is one
// the fits' wander model takes (at
// least the shortest of estimate.tau_grid_s): short dwells pooled do not show a wander of
// minutes. The run is still tested against it as against a given wander
// (run_agrees_with_specified). Returns whether it took one.
// `from` names whose curves they are (FitNoiseOptions::specified_from): the recording's own, or
// the unit's static recording, which is taken on the same conditions.
bool take_recording_wander(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                           const std::string& from = kWanderFromRecording);
// Where the fit estimates the noise and no size of the unit's wander is given (a correlation
// time may be), takes the recording's own Allan curves where they show no wander
// (AllanFinding::wander_curves) to weigh the wander's sizes beside the rows
// (FitNoiseOptions::wander_curves_ug): only curves that reach the shortest correlation time
// of the fits' wander model (estimate.tau_grid_s, 60 s, whatever time was given: a long dwell
// or interval), since shorter ones say nothing of a wander of minutes. Sets
// average_over_wander_sizes, through which alone the curves weigh (a stand fit's too), and
// there the sigmas are the average over the sizes alone. Pooled 10 s
// intervals (curves to 3.3 s) had, so weighed with the average replacing the Student-t
// widening, taken a 1x wander's norm-fit biases from 0.79-0.92 to 1.10-1.27 in z-variance
// (bench/noise --runs 1000): the runs weighted for a wander below the bar lost their
// over-widening while those weighted as white stayed at 2.3-3.1. Returns whether it took them.
// `from`: as take_recording_wander's (FitNoiseOptions::wander_curves_from).
bool take_wander_curves(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                        const std::string& from = kWanderFromRecording);
// Whether `options` leave room for that: a caller that fits the curves for it alone can skip
// the fit otherwise.
bool may_weigh_wander_curves(const FitNoiseOptions& options);
// The same for the unit's static recording's curves as the recording's header carries them
// (kHeaderUnitStaticCurves: standcald's runs), from kWanderFromStaticRecording: every later fit
// of the run weighs them as the run's own did. Returns whether it took them; throws
// std::runtime_error naming the recording and the key where the value is not such curves.
bool take_header_static_curves(FitNoiseOptions& options, const Recording& rec);
// Where the fit estimates the noise and nothing of the unit's wander is given, and Allan curves
// see a wander they do not pin (AllanFinding::wander_tau_floor_s: a long dwell of a few of its
// correlation times, which ends before the wander turns over) whose shortest correlation time
// lies above the fits' shortest: the correlation time as known from that floor to the longest
// the fits model (known_tau, open_above; at the floor where it lies beyond), its size estimated
// from the run. One run's rows allow correlation times the curves exclude, the shorter of
// which make the biases' sigmas several times too small where the wander is slow (tau 1200 s:
// docs/calibration.md, "Curves that see a wander they do not pin"). Too long a floor (a
// warm-up still settling) only widens the sigmas. Returns whether it took one. `from`: as
// take_recording_wander's.
bool take_recording_tau_floor(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                              const std::string& from = kWanderFromRecording);
// The same of a floor `floor_s` from elsewhere (the unit's static recording's curves, or the
// one a standcald run's header carries from them: kHeaderUnitStaticTauFloorS).
bool take_tau_floor(FitNoiseOptions& options, double floor_s, const std::string& from);
// The floors under the correlation time that the unit's static recording's curves
// (`static_floor_s`, 0: none) and this recording's own long stretch (`allan`) put, where each sees
// a wander it does not pin: the higher, which excludes more (take_tau_floor). Returns
// whose it took (kWanderFromStaticRecording, kWanderFromRecording), or "" for neither.
std::string take_higher_tau_floor(FitNoiseOptions& options, double static_floor_s,
                                  const std::optional<AllanFinding>& allan);
// "; the floor F s … is set aside: …", for the `how` of a fit or diagnosis that set aside the
// floor `floor_s` (choose_fit_noise).
std::string tau_floor_set_aside_words(double floor_s);
// The longest correlation time of the fits' wander model (estimate.tau_grid_s; 0 for an empty
// grid).
double longest_model_tau_s(const FitNoiseOptions& options);
// A stand fit's use of its recording's own long dwell (a warm-up): the wander its curves pin
// (take_recording_wander), else the correlation time they bound from below
// (take_recording_tau_floor), else, where they show no wander and no other curves bound it
// already, the curves as that bound (take_wander_curves). Returns whether it took any.
bool take_recording_wander_or_bound(FitNoiseOptions& options,
                                    const std::optional<AllanFinding>& allan);
// The shortest correlation time of the fits' wander model (estimate.tau_grid_s; 0 for an empty
// grid): curves that end before it show nothing of a wander of minutes.
double shortest_model_tau_s(const FitNoiseOptions& options);
// Whether `options` leave room for that (estimating, nothing of the unit's given): a caller
// that fits the curves for it alone can skip the fit otherwise.
bool may_take_recording_wander(const FitNoiseOptions& options);

// Weighting as if every dwell mean were independent: for callers that model the noise
// themselves (the diagnosis selects wander and terms together) and for comparisons.
inline FitNoiseOptions white_noise_weighting() {
  FitNoiseOptions o;
  o.mode = FitNoiseOptions::Mode::white;
  return o;
}

// Whether a fit of `rows` measurements and `parameters` unknowns can estimate the wander's
// four parameters (q per axis and tau) and keep a degree of freedom for its chi-square test.
inline bool can_estimate_wander(std::size_t rows, Eigen::Index parameters) {
  constexpr Eigen::Index kWanderParameters = 4;
  return static_cast<Eigen::Index>(rows) > parameters + kWanderParameters;
}

// The noise a result was weighted with, as reported (`noise` in the fit and diagnosis JSON).
struct NoiseFinding {
  std::string model = "white";    // "white" or "gauss_markov"
  std::string source;             // gauss_markov: "estimated" (this recording) or "specified"
  bool bias_instability = false;  // the recording itself shows the wander
  Vec3 wander_ug = Vec3::Zero();  // Gauss-Markov standard deviation per axis
  // The axes whose wander_ug is the specified one, not this run's (NoiseEstimate::
  // axes_specified): the report says so (specified_axes_words).
  std::array<bool, 3> wander_axes_specified{};
  double tau_s = 0;        // its correlation time
  bool tau_given = false;  // given, not estimated (known_tau, or a specified wander)
  // The range of correlation times given (known_tau as a range; 0 when one value).
  double tau_given_min_s = 0, tau_given_max_s = 0;
  // ... known only from below (KnownTau::open_above): tau_given_max_s is the fits' longest.
  bool tau_given_open_above = false;
  // Estimated, or given as a range: the correlation times of the grid the run allows
  // (2 delta log L within plausible_lr of the best); the biases' sigmas are averaged over them.
  double tau_plausible_min_s = 0, tau_plausible_max_s = 0;
  Vec3 allan_peak_ug = Vec3::Zero();  // the Allan-deviation floor that wander shows
  // How much a dwell mean's error exceeds its standard error for the wander between dwells;
  // understated_in_total() adds the samples' own correlation within one (allan).
  Vec3 understated_by = Vec3::Ones();
  double lr = 0, lr_threshold = 0;  // 2 delta log L against white noise, and the bar
  std::string how;
  // FitNoiseOptions::average_over_wander_sizes applied (the wander no finding): the largest
  // wander common to the axes that the run cannot exclude (2 delta log L within
  // plausible_lr); the sigmas are at least their average over those wanders. 0 where not
  // applied.
  double sigmas_allow_wander_up_to_ug = 0;
  // ... and those wanders were weighed by the recording's Allan curves too
  // (FitNoiseOptions::wander_curves_ug), not by the run's rows alone: the sigmas are then
  // that average alone.
  bool sigmas_allowance_weighs_allan_curves = false;
  // Whose curves (FitNoiseOptions::wander_curves_from); empty where none were weighed.
  std::string sigmas_allowance_allan_curves_from;
  // The unit's wander was given to the fit (its size: `--bias-instability-ug`), whether or
  // not the fit weighted with it.
  bool unit_wander_given = false;
  // Where that wander came from: FitNoiseOptions::specified_from ("" the operator,
  // kWanderFromHeader, kWanderFromRecording, kWanderFromStaticRecording).
  std::string unit_wander_from;
  // The Allan deviation of the raw samples, dwells pooled: white density, bias instability
  // and random walk within a dwell, where the wander above is between dwells.
  std::optional<AllanFinding> allan;
  // How much sigma/sqrt(n) understated a dwell mean's error: the wander, and the samples'
  // correlation within the dwell that the standard errors were widened for.
  Vec3 understated_in_total() const {
    if (!allan || !allan->sample_correlation) return understated_by;
    return understated_by.cwiseProduct(allan->sample_correlation->factor);
  }
};

// Whether the correlation time was given (specified with the wander, or known: one value or
// a range) and, where it was estimated or given as a range, the times of the grid the run
// allows (`plausible`: what the sigmas were averaged over).
void set_tau_provenance(NoiseFinding& n, const std::vector<PlausibleNoise>& plausible,
                        const std::optional<KnownTau>& known);

// From the estimate (its noise, or the specified one when the run alone shows none) and the
// dwell means it applies to: understated_by per axis at the median dwell standard error.
// `known_tau`: the correlation time the estimate was made at, when given.
NoiseFinding noise_finding(const NoiseEstimate& e, const std::vector<PositionAverage>& avg,
                           const std::optional<KnownTau>& known_tau = std::nullopt);

// The wander an estimator weights with, chosen by `options` from the white fit's
// linearised problem at its solution (rows, whitened design X and whitened residual y), and
// the finding that reports it.
struct FitNoiseChoice {
  GaussMarkovNoise noise;        // what the estimate and its sigmas are weighted with
  GaussMarkovNoise check_noise;  // what the chi-square model check is made against: the
                                 // wander only when it is a finding (or specified)
  NoiseFinding finding;
  WanderScales scales;                    // empty: the noise is not estimated (white or specified)
  std::vector<PlausibleNoise> plausible;  // estimated: the plausible correlation times
  // Noise parameters of check_noise estimated from the fit's own residuals (the common q,
  // each axis's own, and tau unless given): the chi-square test loses as many degrees of
  // freedom.
  int parameters = 0;
  // The same for `noise`, which may be a wander weighted for below the bar of a finding.
  int weighted_parameters = 0;
  // FitNoiseOptions::average_over_wander_sizes, the wander no finding and no size of the unit's
  // given: the wander's sizes (common to the axes) and correlation times the run allows, with
  // their likelihood relative to the best's (plausible_wander_sizes). The sigmas are widened to
  // their average over them where that is wider than the widening above ...
  std::vector<PlausibleNoise> plausible_sizes;
  // ... or, where the recording's Allan curves weighed them too (FitNoiseOptions::
  // wander_curves_ug), to that average alone.
  bool sizes_weigh_curves = false;
  // The floor Allan curves put under the correlation time (KnownTau::open_above) was not
  // taken: the run's rows do not show the wander under it (choose_fit_noise). The choice is
  // then the fit's without known_tau.
  bool tau_floor_set_aside = false;
  // The floor was taken and the run's wander weighted for: `plausible` holds every correlation
  // time from the floor to the longest the fits model, and the sigmas are the largest over
  // them, not their average by the rows' likelihood. Above the floor the curves cannot tell the
  // times apart, and the rows favour the short end (the fitted biases absorb a slow wander's
  // slow part), where a bias's variance is smallest (docs/calibration.md, "A range that ends
  // beyond the curves, and the sigmas at the slowest time a floor allows").
  bool sigmas_at_slowest_tau = false;
};

// How much each parameter's sigma widens when the noise model is estimated from the run:
// to its variance averaged over the plausible correlation times, weighted by likelihood
// (one run pins tau poorly), then by Student's t for the wander's estimated scales, with
// the effective degrees of freedom of Welch-Satterthwaite over all of them; where the
// wander's sizes were averaged over (FitNoiseChoice::plausible_sizes), at least to that
// average, or to it alone where the recording's Allan curves weighed them.
struct SigmaWidening {
  Eigen::VectorXd factor;  // multiplies sigma
  Eigen::VectorXd dof;     // effective degrees of freedom of the variance at the best model
};
SigmaWidening widen_for_estimated_noise(
    const std::function<Eigen::VectorXd(const GaussMarkovNoise&)>& variances,
    const FitNoiseChoice& choice);
// Whether a run's significant wander `e`, estimated from (rows, X, y), agrees with the
// specified one of `options` (its correlation time given: known_tau): its REML optimum does
// not beat the specified wander (at the range's log-middle, for a range of correlation times)
// by 2 delta log L at P below options.specified_departure_p, or specified_exceeded_p where the
// run's is the larger on some axis. Says which, and by how much, in e.how. Where it departs
// so, e keeps the specified q on the axes where the run's own is smaller (in e.noise and each
// of e.plausible): the laxer bar says nothing of those. The fits and the diagnosis weigh the
// same run's positions alike by it.
bool run_agrees_with_specified(const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X,
                               const Eigen::VectorXd& y, const FitNoiseOptions& options,
                               NoiseEstimate& e);

// The specified wander as the fits weigh with it: at the range's log-middle where its
// correlation time is given as a range.
GaussMarkovNoise specified_at_known_tau(const FitNoiseOptions& options);

// A floor under the correlation time (known_tau open_above) is taken only where the run's
// rows show the wander under it, as a finding; otherwise the choice is made without it
// (FitNoiseChoice::tau_floor_set_aside), and tau_floor_set_aside_words says so in its `how`.
FitNoiseChoice choose_fit_noise(const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X,
                                const Eigen::VectorXd& y, const FitNoiseOptions& options,
                                const std::vector<PositionAverage>& positions);

// Where the fit weighted with a wander estimated from the run alone (no size of the unit's
// given), the advice a report prints beneath its noise line: how to give the unit's
// measured wander instead. Empty otherwise. `static_recording_given`: the unit's static
// recording was given and did not pin the wander, and the command refuses
// --bias-instability-* beside it, so the advice says what would.
std::string unit_wander_advice(const NoiseFinding& n, bool static_recording_given);
// Where the sigmas allow for the wanders the run cannot exclude
// (NoiseFinding::sigmas_allow_wander_up_to_ug), what a report's noise line says of it: "; the
// sigmas allow for a bias wander of up to Q ug that these ROWS [and the unit's static
// recording | and their Allan curves] cannot exclude"; "" where they allow for none.
std::string sigmas_allowance_words(const NoiseFinding& n, const std::string& rows);
// Where some axes' wander is the specified one in a wander estimated from the run
// (NoiseFinding::wander_axes_specified), what a report's noise line says beside the sizes:
// ", x and z at the given size (this run's own is smaller there)"; "" otherwise. (Given: by
// the operator, the header, a static recording or the recording's own curves.)
std::string specified_axes_words(const NoiseFinding& n);

// The peak of the Allan deviation of a Gauss-Markov process (q, tau): the "bias
// instability floor" an Allan plot of this wander would show, and the averaging time at
// which it is reached.
struct AllanPeak {
  double deviation = 0;
  double tau_s = 0;
};
AllanPeak gauss_markov_allan_peak(double q, double tau_s);

}  // namespace standcal
