#include "calib/norm_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "calib/allan.hpp"
#include "calib/parameters.hpp"
#include "calib/report.hpp"
#include "calib/static_noise.hpp"
#include "calib/text.hpp"

namespace standcal {

using nlohmann::json;

namespace {

using Vec9 = Eigen::Matrix<double, 9, 1>;

Vec9 compensation_vector(const NormCompensation& c) {
  Vec9 v;
  v << c.bias, c.scale, c.misalignment;
  return v;
}

// A table of means is its own list of intervals. Rows without a standard error get the
// scatter of the fit itself (two passes), which then cannot also check the model.
std::vector<StaticInterval> intervals_from_means(const RawInput& in, bool& errors_given) {
  std::vector<StaticInterval> out;
  errors_given = true;
  for (const StaticMeanRow& row : in.means) {
    StaticInterval iv;
    iv.mean = row.mean;
    iv.samples = row.samples ? static_cast<std::size_t>(*row.samples) : 0;
    iv.t_start_s = iv.t_end_s = static_cast<double>(out.size());
    if (row.standard_error) {
      iv.standard_error = iv.curve_standard_error = iv.white_standard_error = *row.standard_error;
      iv.sigma =
          *row.standard_error * std::sqrt(std::max<double>(1, static_cast<double>(iv.samples)));
    } else {
      errors_given = false;
    }
    out.push_back(iv);
  }
  return out;
}

void set_common_error(std::vector<StaticInterval>& intervals, const Vec3& se) {
  for (StaticInterval& iv : intervals)
    iv.standard_error = iv.curve_standard_error = iv.white_standard_error = iv.sigma = se;
}

NormFit fit_means_without_errors(std::vector<StaticInterval>& intervals, double g, InputUnits units,
                                 NormFitOptions o, std::vector<std::string>& notes) {
  o.noise = white_noise_weighting();
  set_common_error(intervals, Vec3::Ones());
  const NormFit first = fit_norm(intervals, g, units, o);
  // |f| residual rms (m/s^2) back to input units through the mean scale, with the
  // redundancy's degrees of freedom.
  const double n = static_cast<double>(intervals.size());
  const double rms_in =
      first.norm_residual_rms_mps2 * std::sqrt(n / (n - 9)) * first.compensation.scale.mean();
  set_common_error(intervals, Vec3::Constant(rms_in));
  notes.push_back(
      "the table gives no standard errors: each mean is given the scatter of the fit "
      "itself, so the sigmas rest on it and chi-square cannot check the model");
  return fit_norm(intervals, g, units, o);
}

// How many times at most the norm fit is redone with its intervals' errors beside the wander
// it found, and the change of the wander (each axis's q) that ends it: the errors depend on
// the wander and, where it is estimated, the wander on the errors. Where the wander dominates
// an interval's curve error, what is left beside it is a small difference that settles
// slowly, while the wander moves by a few per cent at most (bench/noise --warmup-hours 1
// --tau-s 60, the wander estimated at a given tau of 60 s: 5 % over five refits, the errors
// then still moving by up to 2.5 %).
constexpr int kMaxWanderRefits = 5;
constexpr double kWanderRefitTolerance = 0.01;

double largest_relative_change(const std::vector<StaticInterval>& now,
                               const std::vector<Vec3>& before) {
  double change = 0;
  for (std::size_t i = 0; i < now.size(); ++i)
    for (int a = 0; a < 3; ++a)
      if (before[i][a] > 0)
        change = std::max(change, std::abs(now[i].standard_error[a] / before[i][a] - 1));
  return change;
}

// The same model at the same correlation time, each axis's q within the tolerance.
bool same_wander(const NoiseFinding& a, const NoiseFinding& b) {
  if (a.model != b.model || a.tau_s != b.tau_s) return false;
  for (int k = 0; k < 3; ++k)
    if (std::abs(b.wander_ug[k] - a.wander_ug[k]) > kWanderRefitTolerance * a.wander_ug[k])
      return false;
  return true;
}

std::vector<Vec3> errors_of(const std::vector<StaticInterval>& intervals) {
  std::vector<Vec3> out;
  out.reserve(intervals.size());
  for (const StaticInterval& iv : intervals) out.push_back(iv.standard_error);
  return out;
}

// `fit`, made with the intervals' curve errors, redone with each interval weighted by its
// error beside the wander the fit weights for between the intervals (errors_beside_wander)
// until the wander settles. A refit that loses the wander, or fails, keeps the fit before it
// (its errors were taken beside a wander the refit would count nowhere); errors that would
// hardly move keep it too. Every way out leaves the intervals with the errors `fit` used.
NormFit refit_beside_wander(std::vector<StaticInterval>& intervals, double g, InputUnits units,
                            const NormFitOptions& o, NormFit fit) {
  for (int k = 0; k < kMaxWanderRefits && fit.result.noise.model == "gauss_markov"; ++k) {
    const std::vector<Vec3> before = errors_of(intervals);
    const auto keep_fit = [&] {
      for (std::size_t i = 0; i < intervals.size(); ++i) intervals[i].standard_error = before[i];
    };
    errors_beside_wander(intervals, fit.result.noise, ug_per_input_unit(fit.compensation, g));
    if (largest_relative_change(intervals, before) < kWanderRefitTolerance) {
      keep_fit();
      break;
    }
    NormFit refit;
    try {
      refit = fit_norm(intervals, g, units, o);
    } catch (const std::runtime_error&) {  // no convergence under the new weights
      keep_fit();
      break;
    }
    if (refit.result.noise.model != "gauss_markov") {
      keep_fit();
      break;
    }
    const bool settled = same_wander(fit.result.noise, refit.result.noise);
    fit = std::move(refit);
    if (settled) break;
  }
  return fit;
}

// Where the fit weighted for a wander between intervals whose errors are the curves' (not
// sigma / sqrt(n)), how those errors were made says they are taken beside it.
void say_errors_beside_wander(StaticDetection& d, const NoiseFinding& n) {
  if (n.model != "gauss_markov") return;
  for (const StaticInterval& iv : d.intervals)
    if (iv.standard_error != iv.curve_standard_error) {
      d.standard_errors_how +=
          "; less the share of the bias wander the fit weights for between the intervals";
      return;
    }
}

Vec3 median_understatement(const std::vector<StaticInterval>& intervals) {
  Vec3 out = Vec3::Ones();
  for (int a = 0; a < 3; ++a) {
    std::vector<double> r;
    for (const StaticInterval& iv : intervals)
      if (iv.white_standard_error[a] > 0)
        r.push_back(iv.curve_standard_error[a] / iv.white_standard_error[a]);
    if (r.empty()) continue;
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    out[a] = r[r.size() / 2];
  }
  return out;
}

ThresholdStability refit_at(const RawInput& in, const NormCalibrationOptions& o, double factor,
                            const NormFit& main) {
  ThresholdStability s;
  s.factor = factor;
  NormCalibrationOptions other = o;
  other.detector.threshold_factor = o.detector.threshold_factor * factor;
  try {
    StaticDetection d = detect_static_intervals(in, other.detector);
    s.intervals = d.intervals.size();
    // Weighted beside the main fit's wander (the same recording's), in one fit rather than
    // redone to its own: the refits are a third of `standcal fit`'s time.
    errors_beside_wander(d.intervals, main.result.noise,
                         ug_per_input_unit(main.compensation, in.g_mps2));
    s.values =
        compensation_vector(fit_norm(d.intervals, in.g_mps2, in.units, other.fit).compensation);
    const Vec9 moved =
        (s.values - compensation_vector(main.compensation)).cwiseQuotient(main.sigma);
    for (int k = 0; k < 9; ++k)
      if (std::abs(moved[k]) > 1)
        s.moved.emplace_back(kNormParameterNames[static_cast<std::size_t>(k)]);
  } catch (const std::exception& e) {
    s.error = e.what();
  }
  return s;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Where the sigmas allow for the wanders the run cannot exclude (the norm fit's
// average_over_wander_sizes), what the Noise line ends with, and what narrows them: the
// unit's wander size, and its correlation time where that was not given either. No advice
// where unit_wander_advice gives its own beneath, nor where the unit's static recording was
// given (`static_given`: the line beneath says what it gave, and why).
std::string allowed_wander_words(const NoiseFinding& n, bool static_given) {
  const std::string out = sigmas_allowance_words(n, "intervals");
  if (out.empty()) return "";
  if (!unit_wander_advice(n, static_given).empty() || static_given) return out;
  return out + (n.tau_given ? " (give the unit's measured wander size, --bias-instability-ug, "
                              "to narrow them)"
                            : " (give the unit's measured wander, --bias-instability-ug with "
                              "--bias-instability-tau-s and --bias-instability-tau-max-s, or a "
                              "long static recording of it, --unit-static-recording, to narrow "
                              "them)");
}

std::string wander_words(const NoiseFinding& n, bool static_given) {
  if (n.model != "gauss_markov")
    return "no bias wander between intervals beyond their own errors" +
           allowed_wander_words(n, static_given);
  return "bias wander between intervals " + fmt("%.0f", n.wander_ug[0]) + ", " +
         fmt("%.0f", n.wander_ug[1]) + ", " + fmt("%.0f", n.wander_ug[2]) +
         " ug (Gauss-Markov, tau " + fmt("%.0f", n.tau_s) + " s, " + n.source + ")" +
         specified_axes_words(n) + ", weighted for" + allowed_wander_words(n, static_given);
}

json vec_json(const Vec3& v) { return json::array({v[0], v[1], v[2]}); }

json intervals_json(const NormCalibration& c) {
  json list = json::array();
  for (std::size_t i = 0; i < c.detection.intervals.size(); ++i) {
    const StaticInterval& iv = c.detection.intervals[i];
    list.push_back({{"start_s", iv.t_start_s},
                    {"end_s", iv.t_end_s},
                    {"samples", iv.samples},
                    {"mean", vec_json(iv.mean)},
                    {"standard_error", vec_json(iv.standard_error)},
                    {"curve_standard_error", vec_json(iv.curve_standard_error)},
                    {"white_standard_error", vec_json(iv.white_standard_error)},
                    {"norm_residual_mps2", c.fit.norm_residual_mps2[i]},
                    {"norm_residual_sigma_mps2", c.fit.norm_residual_sigma_mps2[i]}});
  }
  return {{"how", c.detection.how},
          {"standard_errors_how", c.detection.standard_errors_how},
          {"count", c.detection.intervals.size()},
          {"window_samples", c.detection.window_samples},
          {"quiet_level", c.detection.quiet_level},
          {"threshold", c.detection.threshold},
          {"saturated_samples", c.detection.saturated_samples},
          {"short_runs_dropped", c.detection.short_runs_dropped},
          {"list", list}};
}

}  // namespace

json norm_compensation_to_json(const NormFit& f, const RawInput& in) {
  const NormCompensation& c = f.compensation;
  json m = json::array();
  for (int i = 0; i < 3; ++i) m.push_back(vec_json(c.matrix.row(i).transpose()));
  json cov = json::array();
  for (int i = 0; i < 9; ++i) {
    json row = json::array();
    for (int k = 0; k < 9; ++k) row.push_back(f.covariance(i, k));
    cov.push_back(row);
  }
  return {{"equation", "f = M * (raw - b), M = T * K, T unit upper-triangular"},
          {"source", in.source},
          {"input_units", std::string(to_string(in.units))},
          {"output_units", "m/s^2"},
          {"bias", vec_json(c.bias)},
          {"bias_sigma", vec_json(f.sigma.head<3>())},
          {"matrix", m},
          {"scale", vec_json(c.scale)},
          {"scale_sigma", vec_json(f.sigma.segment<3>(3))},
          {"misalignment",
           {{"m01", c.misalignment[0]}, {"m02", c.misalignment[1]}, {"m12", c.misalignment[2]}}},
          {"misalignment_sigma", vec_json(f.sigma.tail<3>())},
          {"covariance_order",
           json(std::vector<std::string>(kNormParameterNames.begin(), kNormParameterNames.end()))},
          {"covariance", cov}};
}

namespace {

json stability_json(const NormCalibration& c) {
  json out = json::array();
  for (const ThresholdStability& s : c.stability) {
    json e{{"threshold_factor", s.factor}, {"intervals", s.intervals}};
    if (!s.error.empty()) {
      e["error"] = s.error;
    } else {
      json values = json::object();
      for (int k = 0; k < 9; ++k)
        values[std::string(kNormParameterNames[static_cast<std::size_t>(k)])] = s.values[k];
      e["compensation"] = values;
      e["moved_over_1_sigma"] = s.moved;
    }
    out.push_back(e);
  }
  return out;
}

// The Allan figures of static intervals' pooled curves `a` (ug); with `wander`, the wander a
// long interval pins (take_recording_wander), and with `curves` the curves as the wander's
// likelihood (wander_curves: what bounds the wander the sigmas allow for); each left out where
// the fit could not take it, and both where gaps in the intervals' samples distort the curves.
// `fit`, where given, receives the curves' fit (none where it was not made or failed).
AllanFinding fitted_allan_finding(const DwellAllan& a, bool wander, bool curves,
                                  std::optional<GaussMarkovAllanFit>* fit = nullptr) {
  // No sample correlation: the intervals' standard errors already take the curve at their
  // length (coloured_standard_error).
  AllanFinding out{a.sample_period_s, a.segments,   a.figures,
                   std::nullopt,      std::nullopt, a.gaps.warning(kStaticIntervals),
                   std::nullopt};
  if (a.gaps.too_much() || !(wander || curves)) return out;
  const std::vector<std::vector<AllanPoint>> axes{a.curves[0], a.curves[1], a.curves[2]};
  const std::optional<GaussMarkovAllanFit> fitted = fit_gauss_markov_allan(axes, a.sample_period_s);
  if (fit) *fit = fitted;
  if (!fitted) return out;
  if (wander) {
    const double end_s = curves_end_s(axes);
    out.wander = wander_to_give(*fitted, end_s);
    out.wander_tau_floor_s = wander_tau_floor_s(*fitted, end_s);
  }
  if (curves) out.wander_curves = wander_curves(*fitted, axes, a.sample_period_s);
  return out;
}

// The same of this recording's intervals, in ug of the calibrated axes (the fit's
// `noise.allan`, as for stand recordings).
AllanFinding allan_finding_in_ug(const StaticDetection& d, const NormCompensation& k,
                                 const RawInput& in, bool wander, bool curves) {
  return fitted_allan_finding(
      allan_in_ug(d, ug_per_input_unit(k, in.g_mps2), 1.0 / in.sample_rate_hz), wander, curves);
}

std::string static_recording_units_error(const RawInput& s, const RawInput& in) {
  return s.source + ": the unit's static recording is in " + std::string(to_string(s.units)) +
         " and " + in.source + " in " + std::string(to_string(in.units)) +
         ": its curves are put in ug by this fit's scale, so both must be in the same units "
         "(convert one file, or say how each is read: " +
         in.option("units") + ", " + s.option("units") + ")";
}

// The unit's static recording in ug of the norm fit's calibrated axes (its compensation `k` at
// the calibration's g): so in the calibration recording's units.
UnitStaticAllan norm_unit_static_allan(const RawInput& s, const NormCompensation& k,
                                       const RawInput& in, const StaticDetectorOptions& detector);

// Why a static recording gave nothing where the unit's wander was given.
constexpr const char* kGivenWords =
    "the unit's wander or its correlation time was given (--bias-instability-*, or the "
    "recording's header: what its run was made with), or the noise is not estimated";

// The axes given the largest size their curves allow (WanderToGive::axes_at_bound), in words.
std::string at_bound_words(const WanderToGive& w) {
  const std::string axes = axis_names(w.axes_at_bound);
  if (axes.empty()) return "";
  return " (" + axes +
         (axes.size() == 1
              ? " at the largest size its curve allows, at most the largest axis's: it does"
              : " at the largest sizes their curves allow, at most the largest axis's: "
                "they do") +
         " not tell a wander from none)";
}

// The static recording gave the wander its curves pin, weighted with as the unit's.
void say_gave_pinned_wander(UnitStaticRecordingUse& use, const WanderToGive& w) {
  use.gave = "wander";
  use.wander = given_wander_of(w);
  const Vec3 q = use.wander.axes_ug();
  use.why = "its Allan curves pin a wander of " + axes_text("%.3g", q[0], q[1], q[2], "ug") +
            ", correlation time " + fmt("%.0f", w.tau_min_s) + "-" + fmt("%.0f", w.tau_max_s) +
            " s: weighted with as the unit's, each axis with its own" + at_bound_words(w);
}

// A wander the curves bound that take_recording_wander did not take: they do not show the
// slowest of its times turn over (they put a floor under it instead: wander_tau_floor_s), or
// its times are shorter than the fits model.
std::string untaken_wander_words(const WanderToGive& w) {
  const std::string range =
      "correlation time " + fmt("%.0f", w.tau_min_s) + "-" + fmt("%.0f", w.tau_max_s) + " s";
  if (!curves_show_turnover(w.tau_max_s, w.curves_end_s))
    return "its Allan curves see a wander they do not pin (" + range + ", but they end at " +
           fmt("%.0f", w.curves_end_s) +
           " s, before the slowest of those turns over: record about 100 x its correlation time)";
  return "its Allan curves pin a wander of " + range + ", shorter than the fits model";
}

// What curves that bound a wander's correlation time say of it, in words: that they pin it (they
// show it turn over), else why the fits did not take it (untaken_wander_words).
std::string bounded_wander_words(const WanderToGive& w) {
  return curves_show_turnover(w.tau_max_s, w.curves_end_s) ? "its Allan curves pin a wander"
                                                           : untaken_wander_words(w);
}

// Curves that show no wander but end before the shortest correlation time of the fits' model
// (`options`): they say nothing of a wander of minutes.
std::string curves_end_too_soon_words(const FitNoiseOptions& options) {
  return ", but end before the shortest correlation time the fits model (" +
         fmt("%.0f", shortest_model_tau_s(options)) + " s): record longer";
}

// What fitted curves show of a wander, in words, where they pin none (wander_to_give empty) or
// show none.
std::string curves_show_words(const GaussMarkovAllanFit& fit, double end_s) {
  if (!fit.describes_curves)
    return "its Allan curves are not white noise and one wander (motion left in its static "
           "stretches, or a second noise process)";
  if (fit.short_correlation) return "its Allan curves show only the samples' own short correlation";
  if (fit.wander_seen)
    return "its Allan curves see a wander they do not pin (to " + fmt("%.0f", end_s) +
           " s they do not show it turn over: record about 100 x its correlation time)";
  return "its Allan curves (to " + fmt("%.0f", end_s) + " s) show no wander";
}

// Where a fit (`who`: "this fit", "the diagnosis") set aside a floor under the correlation time:
// its `rows` (dwells, intervals, positions) do not show the wander at those times
// (choose_fit_noise, select_terms_and_noise).
std::string floor_set_aside_words(const std::string& rows, const std::string& who = "this fit") {
  return ", a floor " + who + " set aside: this run's " + rows +
         " do not show the wander at those times";
}

// The recording's own long `stretch` (dwell, interval) sees a wander it does not pin: the floor
// it put under the correlation time, and whether the fit (`result`) kept it, which it does only
// where its `rows` show the wander at those times (choose_fit_noise).
std::string recording_tau_floor_words(const std::string& stretch, const std::string& rows,
                                      const NoiseFinding& result) {
  std::string words = "; this recording's own long " + stretch +
                      " sees a wander it does not pin, whose correlation time it bounds from below";
  if (!result.tau_given_open_above) words += floor_set_aside_words(rows);
  return words;
}

// The end of a static recording's `why` where its curves show no wander and were taken to bound
// the one the sigmas allow for: whether they did, in the fit whose noise is `result`, or why
// not (`rows`: the fit's, "intervals" or "dwells"). Returns whether it said one.
bool say_curves_bound(UnitStaticRecordingUse& use, const NoiseFinding& result,
                      const std::string& rows) {
  if (result.sigmas_allowance_allan_curves_from == kWanderFromStaticRecording) {
    use.gave = "bound";
    use.why += ": they bound the wander the sigmas allow for";
  } else if (result.bias_instability) {
    use.why += ", but this run's " + rows + " show a wander of their own, weighted for";
  } else if (result.sigmas_allow_wander_up_to_ug <= 0) {
    use.why += ", and this run's sigmas allow for none they could bound";
  } else {
    return false;
  }
  return true;
}

// `from`'s long stretch put a floor under the correlation time (take_tau_floor: the recording's
// own, or the unit's static recording's; no wander pinned).
bool took_tau_floor(const FitNoiseOptions& taken, const std::string& from) {
  return taken.known_tau && taken.known_tau->open_above && taken.specified_from == from;
}
bool took_recording_tau_floor(const FitNoiseOptions& taken) {
  return took_tau_floor(taken, kWanderFromRecording);
}

// What the unit's static recording's curves, which see a wander they do not pin, say of its
// correlation time.
std::string static_tau_floor_words(double floor_s) {
  return ": they put its correlation time at " + fmt("%.0f", floor_s) + " s or longer";
}

// A correlation time given outranks the curves: the floor they put under it (`floor_s`; 0: none,
// as where they pin a wander), said as not taken.
std::string floor_outranked_words(double floor_s) {
  return (floor_s > 0 ? static_tau_floor_words(floor_s) : std::string()) +
         ", but a correlation time was given, which it does not override";
}

// The floor they put under it (take_higher_tau_floor): whether the fit (`result`) kept it, which
// it does only where its `rows` show the wander at those times (choose_fit_noise). `use.gave`
// says "floor" where it did.
void say_static_tau_floor(UnitStaticRecordingUse& use, const NoiseFinding& result,
                          const std::string& rows) {
  use.why += static_tau_floor_words(use.tau_floor_s);
  if (result.tau_given_open_above) {
    use.gave = "floor";
    // At or beyond the longest the fits model, the floor is the one correlation time weighed.
    use.why += result.tau_given_max_s > 0
                   ? ", which the sigmas allow for up to the longest the fits model, at the "
                     "widest of those times"
                   : ", which the sigmas weigh as its correlation time (at or beyond the longest "
                     "the fits model)";
  } else {
    use.gave = "nothing";
    use.why += floor_set_aside_words(rows);
  }
}

// Where the unit's static recording's curves put a floor (`floor_s`) under the correlation time
// that the recording's own long `stretch` (dwell, interval) outdoes: said, with the floor, as
// passed over for the higher.
void say_lower_static_floor(UnitStaticRecordingUse& use, double floor_s,
                            const std::string& stretch) {
  if (floor_s > 0)
    use.why += static_tau_floor_words(floor_s) +
               ", not above the floor this recording's own long " + stretch +
               " puts, taken instead";
}

// The floor the unit's static recording's curves put under the correlation time: those given
// (`unit_static`), else the one a standcald run's header carries from its own (`rec`); 0: none.
double static_tau_floor_s(const UnitStaticAllan* unit_static, const Recording* rec) {
  return unit_static ? unit_static->allan.wander_tau_floor_s
         : rec       ? rec->unit_static_tau_floor_s
                     : 0.0;
}

// What the unit's static recording's curves gave the fit (`result`: its final noise) and why,
// where they pin no wander it took: `given` are the caller's options, `taken` those the fit was
// made with and `first` the fit without either recording's curves.
void say_static_curves_use(UnitStaticRecordingUse& use, const AllanFinding& allan,
                           const FitNoiseOptions& given, const FitNoiseOptions& taken,
                           const NoiseFinding& first, const NoiseFinding& result) {
  if (result.sigmas_allowance_allan_curves_from == kWanderFromStaticRecording) {
    say_curves_bound(use, result, "intervals");
  } else if (!may_take_recording_wander(given) && !may_weigh_wander_curves(given)) {
    use.why = kGivenWords;
  } else if (allan.wander && !may_take_recording_wander(given)) {
    use.why = bounded_wander_words(*allan.wander) + floor_outranked_words(allan.wander_tau_floor_s);
  } else if (allan.wander && !(allan.wander_tau_floor_s > 0)) {
    use.why = untaken_wander_words(*allan.wander);  // its times shorter than the fits model
  } else if (took_tau_floor(taken, kWanderFromStaticRecording)) {
    use.tau_floor_s = taken.known_tau->min_s;
    say_static_tau_floor(use, result, "intervals");
  } else if (allan.wander_tau_floor_s > 0 && !may_take_recording_wander(given)) {
    use.why += floor_outranked_words(allan.wander_tau_floor_s);
  } else if (allan.wander_tau_floor_s > 0 && took_recording_tau_floor(taken)) {
    say_lower_static_floor(use, allan.wander_tau_floor_s, "interval");
  } else if (taken.specified_from == kWanderFromRecording && !took_recording_tau_floor(taken)) {
    use.why += "; this recording's own long interval pins a wander, weighted with instead";
  } else if (result.sigmas_allowance_allan_curves_from == kWanderFromRecording) {
    use.why += "; this recording's own long interval bounds the wander instead";
  } else if (allan.wander_curves) {
    // Taken as a bound (beside a floor under the correlation time), the fit it bounded says
    // what came of it, as for the stand fits; not taken, the fit without curves says why.
    const bool taken_as_bound = taken.wander_curves_from == kWanderFromStaticRecording;
    if (!say_curves_bound(use, taken_as_bound ? result : first, "intervals"))
      use.why += curves_end_too_soon_words(taken);
  }
}

// What the unit's static recording gave the fit and why (say_static_curves_use), and beside it
// the floor this recording's own long interval put under the correlation time, as the stand
// fits say it (settle_unit_static_use).
void say_unit_static_use(UnitStaticRecordingUse& use, const AllanFinding& allan,
                         const FitNoiseOptions& given, const FitNoiseOptions& taken,
                         const NoiseFinding& first, const NoiseFinding& result) {
  if (result.unit_wander_given && result.unit_wander_from == kWanderFromStaticRecording)
    return say_gave_pinned_wander(use, *allan.wander);
  say_static_curves_use(use, allan, given, taken, first, result);
  if (took_recording_tau_floor(taken))
    use.why += recording_tau_floor_words("interval", "intervals", result);
}

}  // namespace

void say_diagnosis_static_tau_floor(UnitStaticRecordingUse& use, const std::string& floor_from,
                                    const std::string& outcome, const NoiseFinding& noise,
                                    bool fit_said) {
  if (use.gave == "wander" || !(use.tau_floor_s > 0)) return;
  const std::string stretch = fit_said ? "interval" : "dwell";
  const bool pinned_by_recording =
      noise.unit_wander_given && noise.unit_wander_from == kWanderFromRecording;
  if (floor_from.empty() && !pinned_by_recording) return;  // a wander given: said already
  if (!fit_said) use.why += static_tau_floor_words(use.tau_floor_s);
  use.gave = "nothing";
  if (pinned_by_recording) {
    use.why += "; the diagnosis tests the terms against the wander this recording's own long " +
               stretch + " pins instead";
  } else if (floor_from == kWanderFromRecording) {
    use.why += "; the diagnosis takes the higher floor this recording's own long " + stretch +
               " puts under it";
  } else if (outcome == "kept") {
    use.gave = "floor";
    use.why += fit_said ? "; the diagnosis estimates the wander the terms are tested against "
                          "under that floor"
                        : ", under which the diagnosis estimates the wander the terms are "
                          "tested against";
  } else if (outcome == "refused") {
    const char* under =
        fit_said ? "; under that floor the diagnosis" : ", under which the diagnosis";
    use.why +=
        std::string(under) + " estimated a wander beyond its class of unit, not taken as noise";
  } else if (outcome == "set_aside") {
    use.why += fit_said ? "; the diagnosis set that floor aside: this run's positions do not "
                          "show the wander at those times"
                        : floor_set_aside_words("positions", "the diagnosis");
  } else {
    use.why += fit_said ? "; the diagnosis did not weigh that floor: it could not check the model"
                        : ", which the diagnosis did not weigh: it could not check the model";
  }
}

UnitStaticAllan unit_static_allan(const RawInput& s, const Vec3& ug_per_unit,
                                  const StaticDetectorOptions& detector) {
  if (s.format == InputFormat::means)
    throw std::runtime_error(s.source +
                             ": the unit's static recording is a table of means: its Allan "
                             "curves need the raw samples");
  StaticDetectorOptions one_orientation = detector;
  one_orientation.require_orientations = false;  // one orientation held: the classic Allan record
  const StaticDetection d = detect_static_intervals(s, one_orientation);
  if (d.intervals.empty())
    throw std::runtime_error(s.source + ": no static interval in the unit's static recording (" +
                             d.how + ")");
  const DwellAllan a = allan_in_ug(d, ug_per_unit, 1.0 / s.sample_rate_hz);
  UnitStaticAllan out;
  out.allan = fitted_allan_finding(a, true, true, &out.gauss_markov);
  const std::optional<GaussMarkovAllanFit>& fit = out.gauss_markov;
  out.use.source = s.source;
  out.use.warnings = s.warnings;
  for (const StaticInterval& iv : d.intervals) out.use.static_s += iv.t_end_s - iv.t_start_s;
  out.use.curves_end_s = curves_end_s({a.curves[0], a.curves[1], a.curves[2]});
  if (a.gaps.too_much())
    out.use.why = out.allan.gaps_warning;
  else if (!fit)
    out.use.why = "its Allan curves are too short to fit";
  else
    out.use.why = out.allan.wander ? bounded_wander_words(*out.allan.wander)
                                   : curves_show_words(*fit, out.use.curves_end_s);
  return out;
}

UnitStaticAllan stand_unit_static_allan(const RawInput& s, double g_mps2) {
  if (s.units == InputUnits::counts)
    throw std::runtime_error(
        s.source +
        ": the unit's static recording is in counts, which have no scale to ug here: record it "
        "in g or m/s^2, or where its values are not counts say so (" +
        s.option("units") +
        " g|mps2); only the norm fit of a recording without angles scales counts, by its own "
        "compensation");
  const double ug_per_unit = s.units == InputUnits::g ? 1 / kUg : 1 / (g_mps2 * kUg);
  return unit_static_allan(s, Vec3::Constant(ug_per_unit));
}

UnitStaticRecordingUse take_static_recording_pinned_wander(FitNoiseOptions& options,
                                                           const UnitStaticAllan& unit_static) {
  UnitStaticRecordingUse use = unit_static.use;
  if (take_recording_wander(options, unit_static.allan, kWanderFromStaticRecording)) {
    say_gave_pinned_wander(use, *unit_static.allan.wander);
  } else if (!may_take_recording_wander(options)) {
    use.why = kGivenWords;
  } else if (unit_static.allan.wander) {
    use.why = untaken_wander_words(*unit_static.allan.wander);
  }
  return use;
}

void take_static_recording_bound(FitNoiseOptions& options, const UnitStaticAllan& unit_static,
                                 UnitStaticRecordingUse& use) {
  if (!unit_static.allan.wander_curves) return;
  if (take_wander_curves(options, unit_static.allan, kWanderFromStaticRecording)) {
    use.gave = "bound";
    use.why = unit_static.use.why;
  } else if (may_weigh_wander_curves(options)) {
    use.why = unit_static.use.why + curves_end_too_soon_words(options);
  }
}

UnitStaticRecordingUse take_static_recording_for_runs(FitNoiseOptions& options,
                                                      const UnitStaticAllan& unit_static) {
  UnitStaticRecordingUse use = take_static_recording_pinned_wander(options, unit_static);
  if (use.gave == "wander") return use;
  const FitNoiseOptions unbound = options;
  take_static_recording_bound(options, unit_static, use);
  if (use.gave == "bound" && options.wander_curves_ug) {
    // Curves a run's header cannot hold (its readers would refuse every run): given to none.
    // Their floor under the correlation time, if any, is still given (below).
    if (const std::string why =
            wander_curves_text_error(wander_curves_text(*options.wander_curves_ug));
        !why.empty()) {
      options = unbound;
      use.gave = "nothing";
      use.why += "; its curves lie beyond what a run's header holds (" + why +
                 "), so the runs are given none";
    }
  }
  if (use.gave == "bound") {
    use.gave = "curves";  // each fit of a run settles whether they bound it
    use.why += std::string("; each run's header carries them (") + kHeaderUnitStaticCurves +
               "), and a fit of the run weighs them as a bound on the wander its sigmas allow "
               "for where the run shows no wander of its own";
  } else if (const double floor_s = unit_static.allan.wander_tau_floor_s;
             floor_s > kMaxUnitWanderTauS) {
    // Beyond what a run's header holds (its readers refuse it): a wander that slow is an offset.
    use.why += static_tau_floor_words(floor_s) + ", beyond what a run's header holds (" +
               plain_round_trip_text(kMaxUnitWanderTauS) + " s), so the runs are given none";
  } else if (take_tau_floor(options, floor_s, kWanderFromStaticRecording)) {
    use.gave = "floor";  // given to the runs: each fit of a run settles whether it stands
    use.tau_floor_s = options.known_tau->min_s;
    use.why += static_tau_floor_words(use.tau_floor_s) +
               "; each run's header carries that floor (" + kHeaderUnitStaticTauFloorS +
               "), and a fit of the run takes it where the run shows the wander at those times";
  }
  return use;
}

void settle_unit_static_use(UnitStaticRecordingUse& use, const NoiseFinding& result) {
  if (use.gave == "floor") say_static_tau_floor(use, result, "dwells");
  if (use.gave == "bound") {
    use.gave = "nothing";
    if (!say_curves_bound(use, result, "dwells")) use.why += ", which this fit did not weigh";
  }
  if (use.recording_tau_floor) use.why += recording_tau_floor_words("dwell", "dwells", result);
}

std::optional<UnitStaticRecordingUse> take_unit_wander_with_static_recording(
    FitNoiseOptions& options, const Recording& rec, const std::optional<AllanFinding>& allan,
    const UnitStaticAllan* unit_static) {
  take_header_wander(options, rec);
  std::optional<UnitStaticRecordingUse> use;
  if (unit_static) use = take_static_recording_pinned_wander(options, *unit_static);
  // A wander pinned, the static recording's then the recording's own, before either's bound.
  if (take_recording_wander(options, allan)) {
    if (use && (unit_static->allan.wander_curves || unit_static->allan.wander_tau_floor_s > 0))
      use->why += "; this recording's own long dwell pins a wander, weighted with instead";
    return use;
  }
  if (use && use->gave != "wander")
    take_static_recording_bound(options, *unit_static, *use);
  else if (!unit_static)
    take_header_static_curves(options, rec);  // its run's, where standcald's run carried them
  const std::string floor_from =
      take_higher_tau_floor(options, static_tau_floor_s(unit_static, &rec), allan);
  if (floor_from == kWanderFromStaticRecording) {
    if (use) {
      use->gave = "floor";  // until settle_unit_static_use says whether the fit kept it
      use->tau_floor_s = options.known_tau->min_s;
    }
    // Beside it the bound of this recording's own long dwell, where its curves show none (the
    // fit may set the floor aside), as the norm fit takes them.
    if (!options.wander_curves_ug) take_wander_curves(options, allan);
    return use;
  }
  if (floor_from == kWanderFromRecording) {
    if (use) {
      use->recording_tau_floor = true;  // said by settle_unit_static_use
      say_lower_static_floor(*use, static_tau_floor_s(unit_static, nullptr), "dwell");
    }
    return use;
  }
  if (take_recording_wander_or_bound(options, allan) && use)  // its bound: no wander is left
    use->why += "; this recording's own long dwell bounds the wander instead";
  return use;
}

nlohmann::json unit_static_recording_json(const UnitStaticRecordingUse& u) {
  nlohmann::json j = {
      {"source", u.source}, {"static_s", u.static_s}, {"curves_end_s", u.curves_end_s},
      {"gave", u.gave},     {"why", u.why},           {"warnings", u.warnings}};
  if (u.gave == "wander") {
    const Vec3 q = u.wander.axes_ug();
    j["wander_ug"] = {q[0], q[1], q[2]};
    if (u.wander.known_tau)
      j["tau_range_s"] = {u.wander.known_tau->min_s, u.wander.known_tau->max_s};
  }
  if (u.gave == "floor") j["tau_floor_s"] = u.tau_floor_s;
  return j;
}

std::string unit_static_recording_name(const UnitStaticRecordingUse& u) {
  return "the unit's static recording " + u.source + " (" + fmt("%.3g", u.static_s / 3600) +
         " h static)";
}

std::string unit_static_recording_words(const UnitStaticRecordingUse& u) {
  return unit_static_recording_name(u) + " gave " +
         (u.gave == "wander"   ? "its wander"
          : u.gave == "bound"  ? "a bound on the wander"
          : u.gave == "floor"  ? "a floor under the wander's correlation time"
          : u.gave == "curves" ? "its curves, to bound the wander"
                               : "nothing") +
         ": " + u.why;
}

namespace {
UnitStaticAllan norm_unit_static_allan(const RawInput& s, const NormCompensation& k,
                                       const RawInput& in, const StaticDetectorOptions& detector) {
  if (s.units != in.units) throw std::runtime_error(static_recording_units_error(s, in));
  return unit_static_allan(s, ug_per_input_unit(k, in.g_mps2), detector);
}
}  // namespace

std::string gaps_warning(const NormCalibration& c, const RawInput& in) {
  const std::optional<AllanFinding>& allan = c.fit.result.noise.allan;
  return allan && !allan->gaps_warning.empty() ? in.source + ": " + allan->gaps_warning : "";
}

Vec3 ug_per_input_unit(const NormCompensation& k, double g_mps2) {
  return k.matrix.diagonal().cwiseAbs() / (g_mps2 * kUg);
}

void take_curve_errors(std::vector<StaticInterval>& intervals) {
  for (StaticInterval& iv : intervals) {
    if (iv.curve_standard_error.isZero()) iv.curve_standard_error = iv.standard_error;
    iv.standard_error = iv.curve_standard_error;
  }
}

NormFit fit_beside_wander(std::vector<StaticInterval>& intervals, double g, InputUnits units,
                          const NormFitOptions& o) {
  take_curve_errors(intervals);
  return refit_beside_wander(intervals, g, units, o, fit_norm(intervals, g, units, o));
}

void errors_beside_wander(std::vector<StaticInterval>& intervals, const NoiseFinding& n,
                          const Vec3& ug_per_unit) {
  take_curve_errors(intervals);
  if (n.model != "gauss_markov" || !(n.tau_s > 0)) return;
  for (StaticInterval& iv : intervals) {
    const double share = gauss_markov_allan_variance(n.tau_s, iv.t_end_s - iv.t_start_s);
    for (int a = 0; a < 3; ++a) {
      const double q = ug_per_unit[a] > 0 ? n.wander_ug[a] / ug_per_unit[a] : 0.0;
      const double curve = iv.curve_standard_error[a], white = iv.white_standard_error[a];
      if (!(white > 0)) continue;  // nothing to floor it at: left the curve's
      iv.standard_error[a] = std::sqrt(std::max(white * white, curve * curve - q * q * share));
    }
  }
}

Vec3 white_noise_understatement(const std::vector<StaticInterval>& intervals,
                                const NormCompensation& k, double g, const NoiseFinding& n) {
  const Vec3 q2 = n.model == "gauss_markov" ? Vec3((n.wander_ug * kUg).cwiseAbs2()) : Vec3::Zero();
  const Mat3 m2 = k.matrix.cwiseAbs2() / (g * g);
  Vec3 out = Vec3::Ones();
  for (int a = 0; a < 3; ++a) {
    std::vector<double> r;
    for (const StaticInterval& iv : intervals) {
      const double white2 = m2.row(a).dot(iv.white_standard_error.cwiseAbs2());
      const double total2 = m2.row(a).dot(iv.standard_error.cwiseAbs2()) + q2[a];
      if (white2 > 0) r.push_back(std::sqrt(total2 / white2));
    }
    if (r.empty()) continue;
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    out[a] = r[r.size() / 2];
  }
  return out;
}

namespace {
NormCalibration calibrate(const RawInput& in, const NormCalibrationOptions& o);
}  // namespace

NormCalibration calibrate_without_angles(const RawInput& in, const NormCalibrationOptions& o) {
  try {
    // Nothing of the unit's wander given: a stand recording's header may say what its run was
    // made with (take_header_wander), as the stand fits of it take it.
    NormCalibrationOptions given = o;
    if (in.recording) take_header_wander(given.fit.noise, *in.recording);
    return calibrate(in, given);
  } catch (const std::runtime_error& e) {
    // The fit's own messages know neither the file nor how its intervals were found.
    const std::string what = e.what();
    if (what.rfind(in.source, 0) == 0) throw;
    if (o.unit_static_recording && what.rfind(o.unit_static_recording->source, 0) == 0) throw;
    throw std::runtime_error(in.source + ": " + what);
  }
}

namespace {

NormCalibration calibrate(const RawInput& in, const NormCalibrationOptions& o) {
  NormCalibration c;
  if (in.format == InputFormat::means) {
    bool errors_given = false;
    c.detection.intervals = intervals_from_means(in, errors_given);
    c.detection.how = "the table's " + std::to_string(in.means.size()) + " static means";
    c.detection.standard_errors_how =
        errors_given ? "the table's" : "the fit's own scatter (the table gives none)";
    if (errors_given) {
      NormFitOptions fo = o.fit;
      fo.noise = white_noise_weighting();  // a table has no times to model wander over
      c.fit = fit_norm(c.detection.intervals, in.g_mps2, in.units, fo);
    } else {
      c.fit = fit_means_without_errors(c.detection.intervals, in.g_mps2, in.units, o.fit, c.notes);
    }
    if (o.unit_static_recording)
      c.unit_static_recording = UnitStaticRecordingUse{
          o.unit_static_recording->source,
          0,
          0,
          "nothing",
          "this recording is a table of means, with no times to weigh a wander between them",
          {},
          o.unit_static_recording->warnings};
    return c;
  }
  c.detection = detect_static_intervals(in, o.detector);
  if (c.detection.intervals.empty())
    throw std::runtime_error(in.source + ": no static interval found (" + c.detection.how +
                             "): the unit never stayed still long enough");
  try {
    c.fit = fit_norm(c.detection.intervals, in.g_mps2, in.units, o.fit);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(in.source + ": " + e.what() + " (intervals: " + c.detection.how + ")");
  }
  c.understated_by = median_understatement(c.detection.intervals);
  std::optional<AllanFinding> allan = allan_finding_in_ug(c.detection, c.fit.compensation, in,
                                                          may_take_recording_wander(o.fit.noise),
                                                          may_weigh_wander_curves(o.fit.noise));
  // Nothing of the unit's wander given: the one a long static interval's Allan curves pin, as
  // the stand fits take it (take_recording_wander), else the floor they put on its correlation
  // time where they see one they do not pin, the higher of the static recording's and this
  // recording's own (take_higher_tau_floor); the fit made again.
  // Either way, a wander weighted for between the intervals is taken out of their errors.
  // Otherwise, where the sigmas allow for a wander the intervals cannot exclude, the curves
  // weigh it too where they reach the wander's times (take_wander_curves): the fit is made
  // again with them.
  // The unit's static recording, where given, is taken before this recording's own.
  std::optional<UnitStaticAllan> unit_static;
  if (o.unit_static_recording)
    unit_static =
        norm_unit_static_allan(*o.unit_static_recording, c.fit.compensation, in, o.detector);
  const std::optional<AllanFinding> static_allan =
      unit_static ? std::optional<AllanFinding>(unit_static->allan) : std::nullopt;
  const NoiseFinding first = c.fit.result.noise;
  NormCalibrationOptions taken = o;
  if (take_recording_wander(taken.fit.noise, static_allan, kWanderFromStaticRecording) ||
      take_recording_wander(taken.fit.noise, allan)) {
    c.fit = fit_beside_wander(c.detection.intervals, in.g_mps2, in.units, taken.fit);
  } else {
    // The floor beside either's bound (the static recording's, given here or carried in a
    // standcald run's header), as the stand fits take them: the floor may be set aside.
    const double static_floor_s = static_tau_floor_s(unit_static ? &*unit_static : nullptr,
                                                     in.recording ? &*in.recording : nullptr);
    const bool floor = !take_higher_tau_floor(taken.fit.noise, static_floor_s, allan).empty();
    const bool bound =
        first.sigmas_allow_wander_up_to_ug > 0 &&
        (take_wander_curves(taken.fit.noise, static_allan, kWanderFromStaticRecording) ||
         (!unit_static && in.recording &&
          take_header_static_curves(taken.fit.noise, *in.recording)) ||
         take_wander_curves(taken.fit.noise, allan));
    if (floor || bound) c.fit = fit_norm(c.detection.intervals, in.g_mps2, in.units, taken.fit);
    c.fit = refit_beside_wander(c.detection.intervals, in.g_mps2, in.units, taken.fit, c.fit);
  }
  if (unit_static) {
    say_unit_static_use(unit_static->use, unit_static->allan, o.fit.noise, taken.fit.noise, first,
                        c.fit.result.noise);
    c.unit_static_recording = unit_static->use;
  }
  say_errors_beside_wander(c.detection, c.fit.result.noise);
  if (!allan->gaps_warning.empty()) c.notes.push_back(allan->gaps_warning);
  c.fit.result.noise.allan = std::move(allan);
  c.fit.result.noise.understated_by = white_noise_understatement(
      c.detection.intervals, c.fit.compensation, in.g_mps2, c.fit.result.noise);
  const bool detected = c.detection.window_samples > 0;
  if (o.stability && detected)
    for (double factor : {0.5, 2.0}) c.stability.push_back(refit_at(in, taken, factor, c.fit));
  return c;
}

}  // namespace

json norm_calibration_to_json(const NormCalibration& c, const RawInput& in) {
  json out = fit_to_json(c.fit.result);
  out["input"] = {{"source", in.source},
                  {"format", std::string(to_string(in.format))},
                  {"units", std::string(to_string(in.units))},
                  {"units_how", in.units_how},
                  {"g_mps2", in.g_mps2},
                  {"g_given", in.g_given},
                  {"samples", in.size()},
                  {"warnings", in.warnings}};
  out["intervals"] = intervals_json(c);
  out["compensation"] = norm_compensation_to_json(c.fit, in);
  out["norm_residual_rms_mps2"] = c.fit.norm_residual_rms_mps2;
  out["iterations"] = c.fit.iterations;
  out["white_noise_understated_by"] = vec_json(c.understated_by);
  out["threshold_stability"] = stability_json(c);
  for (const std::string& n : c.notes) out["notes"].push_back(n);
  if (const std::optional<UnitStaticRecordingUse>& u = c.unit_static_recording)
    out["unit_static_recording"] = unit_static_recording_json(*u);
  return out;
}

std::string format_norm_report(const NormCalibration& c, const RawInput& in) {
  const NormFit& f = c.fit;
  const NormCompensation& k = f.compensation;
  const std::string unit(to_string(in.units));
  std::string out = "standcal calibration report (attitude-free, |f| = g)\n";
  out += "====================================================\n";
  out += "Recording:  " + in.source + " (" + std::string(to_string(in.format)) + ", " + unit +
         ": " + in.units_how + ")\n";
  out += "Gravity:    " + fmt("%.5f", in.g_mps2) + " m/s^2" +
         (in.g_given ? "" : " (ASSUMED standard gravity)") + "\n";
  out += "Intervals:  " + std::to_string(c.detection.intervals.size()) + " static, " +
         c.detection.how + "\n";
  if (c.detection.saturated_samples > 0)
    out += "            " + std::to_string(c.detection.saturated_samples) +
           " samples at the converter's limits excluded\n";
  for (const std::string& w : in.warnings) out += "WARNING:    " + w + "\n";
  if (c.unit_static_recording)
    for (const std::string& w : c.unit_static_recording->warnings) out += "WARNING:    " + w + "\n";
  out += "\nCompensation f = M (raw - b), M = T K (value +- 1 sigma):\n";
  const char* axes = "xyz";
  for (int a = 0; a < 3; ++a)
    out += std::string("  bias ") + axes[a] + "   " + fmt("%14.6g", k.bias[a]) + " +- " +
           fmt("%.3g", f.sigma[a]) + " " + unit + "\n";
  for (int a = 0; a < 3; ++a)
    out += std::string("  scale ") + axes[a] + "  " + fmt("%14.6g", k.scale[a]) + " +- " +
           fmt("%.3g", f.sigma[3 + a]) + " " + unit + " per m/s^2\n";
  for (int a = 0; a < 3; ++a)
    out += "  " + std::string(kNormParameterNames[static_cast<std::size_t>(6 + a)]) + "     " +
           fmt("%+14.6f", k.misalignment[a]) + " +- " + fmt("%.3g", f.sigma[6 + a]) + "\n";
  if (in.units != InputUnits::counts) {
    out += "\nUnit parameters against nominal (value +- 1 sigma):\n";
    for (int j = 0; j < kUnitParameterCount; ++j) {
      const ParameterEstimate& p = f.result.unit[static_cast<std::size_t>(j)];
      if (!p.value) continue;
      out += "  " + std::string(kUnitParameterNames[static_cast<std::size_t>(j)]) + " " +
             fmt("%+12.2f", *p.value * report_scale(j)) + " +- " +
             fmt("%.2f", *p.sigma * report_scale(j)) + " " +
             std::string(kUnitParameterUnits[static_cast<std::size_t>(j)]) + "\n";
    }
  }
  out += "\nModel check: |f| - g rms " + fmt("%.3g", f.norm_residual_rms_mps2 / in.g_mps2 / kUg) +
         " ug over " + std::to_string(c.detection.intervals.size()) + " intervals; chi2/dof " +
         fmt("%.2f", f.result.chi2_dof) + " (redundancy " + std::to_string(f.result.redundancy) +
         ")\n";
  // What the unit's static recording gave: this fit's, else what standcald's gave the run the
  // recording is of (its header's words, beside the curves it may carry), as the stand report.
  const std::optional<UnitStaticRecordingUse>& unit_static = c.unit_static_recording;
  const std::string static_words = unit_static    ? unit_static_recording_words(*unit_static)
                                   : in.recording ? run_unit_static_recording_words(*in.recording)
                                                  : "";
  out += "Noise:      " + wander_words(f.result.noise, !static_words.empty()) + "\n";
  if (const std::string advice = unit_wander_advice(f.result.noise, !static_words.empty());
      !advice.empty())
    out += "            " + advice + "\n";
  if (!static_words.empty()) out += "            " + static_words + "\n";
  out += "            within an interval, white noise would understate a mean's error by x" +
         fmt("%.2f", c.understated_by[0]) + ", x" + fmt("%.2f", c.understated_by[1]) + ", x" +
         fmt("%.2f", c.understated_by[2]) + " (" + c.detection.standard_errors_how + ")\n";
  for (const ThresholdStability& s : c.stability) {
    out += "Threshold x" + fmt("%.1f", s.factor) + ": ";
    if (!s.error.empty())
      out += "refit failed: " + s.error + "\n";
    else if (s.moved.empty())
      out += std::to_string(s.intervals) + " intervals, no parameter moves by more than 1 sigma\n";
    else {
      out += std::to_string(s.intervals) + " intervals; moved by more than 1 sigma:";
      for (const std::string& m : s.moved) out += " " + m;
      out += "\n";
    }
  }
  if (!c.notes.empty() || !f.result.notes.empty()) {
    out += "\nNotes:\n";
    for (const std::string& n : c.notes) out += "  - " + n + "\n";
    for (const std::string& n : f.result.notes) out += "  - " + n + "\n";
  }
  return out;
}

}  // namespace standcal
