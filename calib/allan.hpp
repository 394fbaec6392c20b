#pragma once
// Overlapping Allan deviation of a sampled signal (IEEE Std 952 / 1293 conventions) and
// the three noise figures read off it: white-noise density, bias instability, random walk.
#include <algorithm>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/recording.hpp"

namespace standcal {

struct AllanPoint {
  double tau_s = 0;
  double deviation = 0;  // same unit as the samples
  long terms = 0;        // second differences averaged (confidence falls as this falls)
};

// The overlapping Allan deviation pooled over segments handed over one at a time, so that
// a reader can give each dwell and drop it: memory is one segment, not the recording.
// Time is O(samples x tau points); the sums use four running partial sums (vectorised).
class AllanAccumulator {
 public:
  explicit AllanAccumulator(double sample_period_s, int points_per_decade = 10);
  // Adds one contiguous segment. It is consumed: overwritten with its phase (the integrated
  // signal, one value longer), which saves a copy the size of the segment.
  void add_segment(std::vector<double>& samples);
  // tau from one sample to a third of the longest segment, about points_per_decade values
  // per decade; taus no segment reached are left out.
  std::vector<AllanPoint> curve() const;
  std::size_t segments() const { return segments_; }
  double sample_period_s() const { return sample_period_s_; }

  // Keep each segment's sums from now on, so that another accumulator can take them in
  // (append): a file read in two parts at once pools its dwells as one read in order.
  void keep_segment_sums() { keep_segment_sums_ = true; }
  // Adds `later`'s segments (kept with keep_segment_sums from its start) after this one's
  // own: the same sums added in the same order, so the curve is, bit for bit, the one of
  // adding those segments here. Both must have the same sample period and spacing.
  void append(const AllanAccumulator& later);

 private:
  struct SegmentSums {
    long phase_length = 0;     // samples + 1
    std::vector<double> sums;  // per cluster size, while the segment is long enough
  };
  // Adds one segment's sums (the shared end of add_segment and append).
  void add_sums(long phase_length, std::size_t samples, const std::vector<double>& sums);

  // Extends the cluster sizes (10^(i / points_per_decade), rounded, distinct) to max_m.
  void extend_cluster_sizes(long max_m);

  double sample_period_s_;
  int points_per_decade_;
  long next_exponent_step_ = 0;
  std::size_t longest_ = 0;
  std::size_t segments_ = 0;
  std::vector<long> cluster_sizes_;
  std::vector<double> sum_sq_;  // per cluster size: sum of squared second differences
  std::vector<long> terms_;
  bool keep_segment_sums_ = false;
  std::vector<SegmentSums> kept_;
};

// Overlapping Allan deviation over one or more contiguous segments sampled every
// sample_period_s (segments pool their second differences, so the static dwells of a
// run can be combined). tau runs from one sample to a third of the longest segment,
// about points_per_decade values per decade.
std::vector<AllanPoint> overlapping_allan_deviation(
    const std::vector<std::vector<double>>& segments, double sample_period_s,
    int points_per_decade = 10);

struct NoiseFigures {
  // White noise N (unit/sqrt(Hz)): the slope -1/2 line read at tau = 1 s, so that the mean
  // of a T-second dwell has sigma N / sqrt(T) (docs/model.md convention).
  std::optional<double> white_density;
  // Bias instability B (unit): the flat minimum of the curve / 0.664.
  std::optional<double> bias_instability;
  double bias_instability_tau_s = 0;
  // Rate random walk K (unit / sqrt(s)): the slope +1/2 line read at tau = 3 s.
  std::optional<double> random_walk;
};

// Reads the figures off a curve: each from the points whose local log-log slope is near
// its signature slope (-1/2 before the minimum, +1/2 after it).
NoiseFigures noise_figures(const std::vector<AllanPoint>& curve);

// The Allan variance at averaging time T of a first-order Gauss-Markov process of unit
// variance and correlation time tau_c: (2 (x - e) - e^2) / x^2 with x = T / tau_c and
// e = 1 - exp(-x). It rises as 2x/3 (a random walk) for T << tau_c, peaks near
// T = 1.89 tau_c at 0.38, and falls as 2 / x (white) for T >> tau_c.
double gauss_markov_allan_variance(double tau_c_s, double T_s);

// White noise and one Gauss-Markov wander fitted to the Allan curves of the axes, with one
// correlation time for them all (as the fits' noise model has): per axis sigma^2(T) =
// N^2 / T + q^2 gauss_markov_allan_variance(tau_c, T), one point per octave (overlapping
// estimates at nearby T share most of their clusters), each a Gamma variable of about
// terms * tau0 / T independent clusters, by maximum likelihood with tau_c profiled over a
// log grid. This is
// what a long static recording says of the unit's correlation time, which one calibration
// run cannot pin (docs/calibration.md, "The correlation time, given").
struct GaussMarkovAllanFit {
  // The white noise per axis, unit / sqrt(Hz): N beside the wander, white noise's alone where
  // none is seen, and what a dwell mean sees where the correlation is short.
  std::vector<double> white_density;
  std::vector<double> q;  // the wander's stationary standard deviation per axis
  // Where a wander is seen, the q per axis the curves allow: its profile deviance (white
  // noise, the other axes and tau_c free) within kGaussMarkovSizeRangeDeviance of the best
  // (scaled like tau_c's range); q_max infinite where a wander too slow for the curves could
  // be of any size. Empty otherwise.
  std::vector<double> q_min, q_max;
  double tau_s = 0;  // its correlation time tau_c
  // The correlation times the curves allow: the profile's deviance within
  // kGaussMarkovTauRangeDeviance of the best (scaled by the deviance per degree of freedom
  // when that exceeds 1), each end out to the next point of the grid (20 a decade).
  double tau_min_s = 0, tau_max_s = 0;
  // Some axis has q > 0, the wander beats white noise alone by more than
  // kGaussMarkovWanderDeviance (scaled like the range), and its correlation is not short;
  // otherwise q is 0.
  bool wander_seen = false;
  double wander_deviance = 0;  // white noise alone's deviance less the fit's
  // The correlation times the curves allow all lie below short_correlation_limit_s, and it
  // beats white noise alone by kShortCorrelationDeviance (below that bar, white noise is the
  // model reported): the samples are correlated over a few sample periods (the unit's output
  // filter or decimation), which is no bias wander: any dwell averages it down as white noise.
  // wander_seen is then false, q 0, and white_density the white noise a dwell mean sees,
  // sqrt(N^2 + 2 q^2 tau_c); short_q keeps that correlation's q (tau_s and the range its time).
  bool short_correlation = false;
  std::vector<double> short_q;
  bool tau_open_above = false;  // the range reaches the search's end: tau_max_s is no bound
  // A wander is seen and both ends of its range lie inside the search (the shortest averaging
  // time to 30 x the longest). The curves show it turn over only where they also reach the Allan
  // peak of the range's longest time (curves_show_turnover); short of it, and without a bounded
  // range, they give only a bound (the curve ends while the wander still looks like a random
  // walk, or the range reaches down to the shortest averaging time).
  bool tau_bounded = false;
  // Scatter about the model reported (white noise alone where no wander nor short correlation
  // is seen) relative to the points' confidence.
  double deviance_per_dof = 0;
  // deviance_per_dof within kGaussMarkovFitScatterLimit: white noise and one correlation time
  // describe the curves. Otherwise they have structure the model lacks (motion left in the
  // static intervals, a second noise process), and its figures are only a summary.
  bool describes_curves = true;
  // The point that departs most from the model reported (its largest share of the deviance):
  // where to look on the curve. ratio is the measured deviation over the model's.
  struct Departure {
    std::size_t axis = 0;
    double tau_s = 0;
    double ratio = 1;
    double deviance = 0;
  } worst_departure;
};
// On 700 simulated static recordings of the model itself (bench/noise/allan_tau_main.cpp)
// the deviance per degree of freedom was at most 1.03; imu_tk's Xsens recording gives 22.
inline constexpr double kGaussMarkovFitScatterLimit = 2;
// A correlation over at most a second, or ten sample periods where these are longer, is the
// samples' own: an output filter settles in a few periods, a dwell lasts seconds at least,
// and the fits' wander model takes tau_c of minutes.
inline constexpr double kShortCorrelationMaxS = 1;
inline constexpr double kShortCorrelationSamplePeriods = 10;
inline double short_correlation_limit_s(double sample_period_s) {
  return std::max(kShortCorrelationMaxS, kShortCorrelationSamplePeriods * sample_period_s);
}
// The deviance by which a short correlation must beat white noise alone: chi2 with four
// parameters at P = 1e-6. On diagnostic32's dwells (10 s at 25 Hz) white noise alone had met
// kGaussMarkovWanderDeviance with a short range in 2 of 1000 runs (deviance 18.7 and 19.4),
// and a filter of half a sample period to two beat white noise by 360-13000.
inline constexpr double kShortCorrelationDeviance = 33.4;
// The likelihood-ratio interval for one parameter at about 95 % (chi2_1 = 3.84). Measured on
// simulated static recordings (white 10 ug/rtHz and Gauss-Markov of 1-10 ug, tau_c 60-1200
// s, 2 to 8 hours; 100 seeds each, bench/noise/allan_tau_main.cpp): the range held the true
// tau_c in 93-97 % of them (docs/calibration.md).
inline constexpr double kGaussMarkovTauRangeDeviance = 4;
// The bound of q's range (GaussMarkovAllanFit::q_min, q_max). Not chi2_1's 3.84: the points
// of one curve are not independent (one slow realisation of the wander sets every long
// averaging time), so the profile's curvature overstates what the curves know of q. At 4 the
// range held the true q on 79-92 % of axes, at 9 on 94-99 % (simulated static recordings,
// white 10 ug/rtHz and Gauss-Markov of 1-10 ug, tau_c 60-1200 s, 2 to 8 hours; 40 and 100
// seeds each, bench/noise/allan_tau_main.cpp; docs/calibration.md).
inline constexpr double kGaussMarkovSizeRangeDeviance = 9;
// The deviance by which a wander must beat white noise alone to be seen: chi2 with four
// parameters (three axes' q and tau_c) at P = 1e-3, the bar the fits' noise model sets.
inline constexpr double kGaussMarkovWanderDeviance = 18.5;
inline constexpr std::size_t kGaussMarkovFitMinPoints = 5;
// nullopt when a curve has fewer than kGaussMarkovFitMinPoints octaves.
std::optional<GaussMarkovAllanFit> fit_gauss_markov_allan(
    const std::vector<std::vector<AllanPoint>>& axis_curves, double sample_period_s);

// The unit's wander as a static recording's curves give it to the fits: where the fit sees a
// wander, bounds its correlation time inside the curves and describes them (`standcal noise`'s
// advice; a calibration recording's own long dwell, take_recording_wander; the fits take it only
// where the curves show it turn over: curves_show_turnover): each axis's size,
// a unit's axes wandering each its own (docs/calibration.md, "Each axis its own size").
struct WanderToGive {
  double q = 0;  // the largest axis's q, in the curves' unit
  // Each axis's q; where its curves do not tell a wander from none (its q_min 0; not the
  // largest axis), the largest size they allow it (its q_max, at most q) instead of its fit, which
  // may be 0 by chance: a size too small is what makes that axis's bias sigma too small, one too
  // large only widens it.
  std::vector<double> q_axes;
  std::vector<bool> axes_at_bound;      // the axes given their bound so
  double q_min = 0, q_max = 0;          // the sizes the curves allow it (q_max infinite: no bound)
  double tau_min_s = 0, tau_max_s = 0;  // the correlation times they allow
  double curves_end_s = 0;              // the longest averaging time of the curves
};
std::optional<WanderToGive> wander_to_give(const GaussMarkovAllanFit& fit, double curves_end_s);
// Where the fit sees a wander that has not turned over by the curves' end (its correlation time
// open above: no WanderToGive; or bounded at a longest time whose Allan peak lies beyond the
// curves' longest averaging time `curves_end_s`: curves_show_turnover, which the fits do not
// take as pinned: take_recording_wander), the shortest
// correlation time it allows, s: what the curves do say of the unit's (a two-hour warm-up of a
// 1200 s wander, 6 tau, lower-bounds it so in about 4 of 5 recordings,
// bench/noise/allan_tau_main.cpp). 0 otherwise, and where the curves do not describe white
// noise and one wander. Until 2026-12-07 a bounded range gave no floor, and one beyond the
// curves' end gave the fits nothing (docs/calibration.md, "A range that ends beyond the
// curves").
double wander_tau_floor_s(const GaussMarkovAllanFit& fit, double curves_end_s);
// A Gauss-Markov wander's Allan deviation peaks at about 1.89 x its correlation time
// (gauss_markov_allan_peak); below that it still rises as a random walk's, whose slope pins only
// q^2 / tau_c.
inline constexpr double kGaussMarkovAllanPeakPerTau = 1.89;
// Whether curves ending at `curves_end_s` reach the Allan peak of a wander of the longest
// correlation time they allow (`tau_max_s`): they then show it turn over at every time they
// allow, and its size at each. Short of it, the size they give is the one at their best-fitting
// time, too small at the range's slow end: two-hour static recordings of a 1200 s wander (curves to
// 1995 s) gave ranges such as 385-1916 s with the size 0.49-0.58 x the simulated in q^2, and
// the biases' z-variance 2.4-3.8 on the runs given them (docs/calibration.md, "A range that
// ends beyond the curves").
bool curves_show_turnover(double tau_max_s, double curves_end_s);
// The longest averaging time of any of the curves (0 for none).
double curves_end_s(const std::vector<std::vector<AllanPoint>>& curves);

// One axis's curve as the fits weigh it: one point per octave (kFitPointSpacing), each with
// the independent clusters behind it (its confidence).
struct ThinnedAllanCurve {
  std::vector<AllanPoint> points;
  std::vector<double> clusters;
};

// What a recording's own Allan curves say of a wander common to the axes, as a likelihood:
// their Gamma deviance (fit_gauss_markov_allan's) with the wander held at q on every axis and
// correlation time tau_c, each axis's white noise at its best. A long static stretch that
// shows no wander excludes one its curves would show, which a run's dwell means, one per
// interval, cannot (the norm fit's average over the wander's sizes weighs by both:
// FitNoiseOptions::wander_curves_ug).
struct WanderCurves {
  std::vector<ThinnedAllanCurve> axes;
  // Multiplies the deviance: kWanderCurvesDevianceScale, over the deviance per degree of
  // freedom where the curves scatter beyond the model.
  double deviance_scale = 1;
  double curves_end_s = 0;  // the longest averaging time: shorter wanders are all they can show
  // 2 x the negative log-likelihood, up to a constant, of q (the curves' unit) and tau_c;
  // q = 0 is white noise alone.
  double deviance(double q, double tau_c_s) const;
};
// Curves as one line of JSON, a recording header's value (standcald's runs carry their unit's
// static recording's: kHeaderUnitStaticCurves), and back. Every number round-trips exactly, so
// a later fit of the run weighs them as the run's own did; the points keep what the deviance
// reads (averaging time, deviation, clusters), not their terms. The parser throws
// std::invalid_argument naming what is wrong (wander_curves_text_error, calib/recording.hpp,
// says it, for the recording reader).
std::string wander_curves_text(const WanderCurves& curves);
WanderCurves parse_wander_curves(std::string_view text);
// chi2_1's 3.84 (a 95 % interval for one parameter) over kGaussMarkovSizeRangeDeviance: the
// points of one curve are not independent, and their profile's curvature overstates what they
// know of q (the range at 4 held the true q on 79-92 % of axes, at 9 on 94-99 %), so a
// deviance of 9 from the curves counts as 3.84 would from independent data.
inline constexpr double kWanderCurvesDevianceScale = 3.84 / kGaussMarkovSizeRangeDeviance;
// Of curves that show no wander (`fit`, their fit_gauss_markov_allan: wander_seen false, where
// white noise describes them and they have no short correlation, an output filter's excess
// at the first octaves that would pull on every wander alike); nullopt otherwise. Curves that
// see a wander they do not pin (the wander is taken where they do: take_recording_wander)
// are not weighed: a warm-up still settling after power-on shows as a large slow wander that
// the intervals after it do not have, and weighed so it took the norm fit's biases under
// white noise to 0.11-0.15 in z-variance (bench/noise --runs 300 --warmup-hours 2
// --warmup-transient-ug 30; docs/calibration.md).
std::optional<WanderCurves> wander_curves(const GaussMarkovAllanFit& fit,
                                          const std::vector<std::vector<AllanPoint>>& curves,
                                          double sample_period_s);

// The sampling period of a recording: its sample_rate_hz header, else the median step
// between samples of one position. Throws naming the recording when neither exists.
double sample_period_s(const Recording& rec);
// That median step, from the steps between consecutive samples of one position; nullopt
// when there are none.
std::optional<double> median_step_s(std::vector<double> steps_s);
// Why a median step gives no sample period ("repeated time stamps ..."), or "" when it gives
// one: a step of zero, or one shorter than 1e6 samples a second allow (times in another unit;
// steps of 1e-300 s made a rate of 1e300 Hz, and a window of that many samples overflowed
// its integer).
std::string unusable_step_text(double step_s);

// The samples' own correlation as it bears on a dwell mean: sigma / sqrt(n) takes the samples
// as independent, and the mean of correlated ones has the error of the white noise a dwell
// sees, sqrt(N^2 + 2 q^2 tau_c) per sqrt(Hz) (GaussMarkovAllanFit::short_correlation),
// against sigma sqrt(tau0) from the samples' own scatter.
struct SampleCorrelation {
  double tau_s = 0, tau_max_s = 0;  // the correlation time and the most the curves allow
  double sample_period_s = 0;
  Vec3 dwell_white = Vec3::Zero();  // the white noise a dwell mean sees, per sqrt(Hz), ug
  // A dwell mean's standard error over sigma / sqrt(n), per axis, as the averages widened by
  // it found (widen_for_sample_correlation, calib/averaging.hpp): at least 1 (a filter that
  // anticorrelated the samples would not be trusted to shrink a sigma).
  Vec3 factor = Vec3::Ones();
};
// What a dwell mean's standard error is to be widened by, per axis: the white noise a dwell
// mean sees over sigma sqrt(tau0), sigma the samples' own scatter pooled over the dwells
// (ug); never below 1 (a filter that anticorrelated the samples would not be trusted to
// shrink a sigma), and 1 on an axis without scatter.
Vec3 widening_factor(const SampleCorrelation& correlation, const Vec3& sample_sigma_ug);
// Of the dwells' pooled curves (ug): nothing where the fit sees no short correlation, or the
// curves are too short to fit (fewer than kGaussMarkovFitMinPoints octaves: dwells under
// about 50 samples are never widened).
std::optional<SampleCorrelation> sample_correlation(
    const std::array<std::vector<AllanPoint>, 3>& curves, double sample_period_s);
// The same of curves already fitted.
std::optional<SampleCorrelation> sample_correlation_of(const GaussMarkovAllanFit& fit,
                                                       double sample_period_s);

// Time missing inside a recording's dwells (or a raw recording's static intervals: the
// stretches its samples are pooled from). The Allan curves take a dwell's samples as evenly
// spaced, so gaps shorten the correlation times they show. The time missing is the dwells'
// span beyond their samples' count of periods, so that receive-time jitter (a late sample
// and an early one) cancels; `count` is the steps longer than 1.5 periods, for the words.
struct DwellGaps {
  std::size_t count = 0;
  std::size_t steps = 0;
  double spanned_s = 0;  // every step between a dwell's samples, summed
  double sample_period_s = 0;
  void add_step(double step_s, double period_s);
  void add(const DwellGaps& other);
  double missing_s() const {
    return std::max(0.0, spanned_s - static_cast<double>(steps) * sample_period_s);
  }
  // The other way: the steps at the sample period claim more time than the samples' stamps
  // span (a rate given lower than the stamps', or stamps that bunch): the curves' time axis
  // is stretched, and gaps in the samples hide in the surplus.
  double beyond_stamps_s() const {
    return std::max(0.0, static_cast<double>(steps) * sample_period_s - spanned_s);
  }
  double missing_share() const { return spanned_s > 0 ? missing_s() / spanned_s : 0; }
  // The time the stamps and the steps at the sample period disagree by, either way, as a
  // share of the stamps' span.
  double mismatch_share() const {
    return spanned_s > 0 ? (missing_s() + beyond_stamps_s()) / spanned_s : 0;
  }
  // More than kMaxDwellGapShare of the dwells' time missing, or claimed beyond the stamps.
  bool too_much() const;
  // "" unless too_much(); else what the gaps do to the curves, for the recording's warnings.
  // `stretches` names what the samples were held in ("dwells", "static intervals").
  std::string warning(std::string_view stretches = "dwells") const;
};
// Beyond this share of the dwells' time in gaps no wander is read off their curves: a
// two-hour dwell with 28 % of its time in gaps (standcald's chunks before collect_more) showed
// a wander of 60 s as one of 35-55 s; a unit's odd lost sample is far below it.
inline constexpr double kMaxDwellGapShare = 0.01;

// The Allan deviation of each axis over a recording's dwells pooled: each position block is
// one static segment (the moves are not samples), in ug, with the figures read off it.
struct DwellAllan {
  double sample_period_s = 0;
  std::size_t segments = 0;
  DwellGaps gaps;
  std::array<std::vector<AllanPoint>, 3> curves;        // ug
  std::array<NoiseFigures, 3> figures;                  // ug/sqrt(Hz), ug, ug/sqrt(s)
  std::optional<SampleCorrelation> sample_correlation;  // set by finish_dwell_allan
  std::optional<WanderToGive> wander;                   // set by finish_dwell_allan (ug)
  std::optional<WanderCurves> wander_curves;            // likewise, where they show none
  double wander_tau_floor_s = 0;                        // likewise (wander_tau_floor_s)
};
// Throws std::runtime_error naming the recording when it has fewer than kMinAllanSamples.
inline constexpr std::size_t kMinAllanSamples = 30;
DwellAllan dwell_allan(const Recording& rec);
// The curves and figures of three axes' pooled accumulators (samples in ug); no wander where
// `gaps` hold more than kMaxDwellGapShare of the dwells' time.
DwellAllan finish_dwell_allan(double sample_period_s, const std::array<AllanAccumulator, 3>& pooled,
                              const DwellGaps& gaps = {});

// The figures alone, as the fit's noise model reports them (`noise.allan`); empty when the
// recording has too few samples or no rate.
struct AllanFinding {
  double sample_period_s = 0;
  std::size_t segments = 0;
  std::array<NoiseFigures, 3> figures;
  std::optional<SampleCorrelation> sample_correlation;
  // The wander whose correlation time the curves bound, in ug: what the fits take as the unit's
  // where none is given and the curves show it turn over (a dwell long enough:
  // take_recording_wander, noise_model.hpp); where they do not, wander_tau_floor_s is set too.
  std::optional<WanderToGive> wander;
  std::string gaps_warning;  // DwellGaps::warning of the dwells (static intervals)
  // The curves as a likelihood of the wander (ug), where they show none (wander_curves) and no
  // gaps distort them: what bounds the wander a fit's sigmas allow for (take_wander_curves).
  std::optional<WanderCurves> wander_curves;
  // Where the curves see a wander they do not pin (wander_tau_floor_s), the shortest
  // correlation time they allow it, s: the fits weigh the unit's at no shorter one
  // (take_recording_tau_floor, noise_model.hpp). 0 otherwise.
  double wander_tau_floor_s = 0;
};
AllanFinding allan_finding_of(const DwellAllan& a);
// `why_none`, where given, is set when a recording of kMinAllanSamples or more has no curve
// (its sample period unknown): a fit then cannot allow for samples correlated within a
// dwell, which the operator is told (allan_unavailable_warning).
std::optional<AllanFinding> allan_finding(const Recording& rec, std::string* why_none = nullptr);
// The warning of a recording long enough for an Allan curve that has none ("" when it has
// one or is too short for one).
std::string allan_unavailable_warning(std::size_t samples, const std::string& why_none);
// The same of a recording whose rate and steps give no sample period, "" when they give one:
// for a caller that draws no curve itself (the diagnosis draws its own).
std::string no_sample_period_warning(const Recording& rec);

}  // namespace standcal
