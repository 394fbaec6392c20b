// `standcal noise`: the Allan deviation of a static recording, its noise figures and the
// Gauss-Markov wander's correlation time to give the fits (issues 3 and 21). A stand
// recording's dwells are pooled as it streams (calib/recording_digest); any other recording
// the raw reader takes has its static intervals found and pooled (calib/static_noise).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "calib/allan.hpp"
#include "calib/atomic_file.hpp"
#include "calib/diagnosis/words.hpp"
#include "calib/json_text.hpp"
#include "calib/noise_model.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording_digest.hpp"
#include "calib/static_noise.hpp"
#include "report/noise/allan_figure.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/input_options.hpp"
#include "tools/standcal/threaded_rows.hpp"

namespace standcal::cli {
namespace {

using nlohmann::json;

struct NoiseOptions {
  std::string recording;
  InputCliOptions input;
  double counts_per_g = 0;  // 0: not given
  bool json = false;
  std::string curve_out;
  std::string plot_out;
};

// The curves and where they came from.
struct NoiseSource {
  std::string name;  // the recording, as its reader names it
  std::size_t samples = 0;
  DwellAllan allan;                // ug
  std::optional<StaticNoise> raw;  // a raw recording: how its static samples were found, scaled
};

NoiseSource read_noise_source(const NoiseOptions& o) {
  if (streams_as_stand_recording(o.input, o.recording)) {
    if (o.counts_per_g > 0)
      throw CLI::ValidationError("--counts-per-g",
                                 o.recording + " is a stand recording in m/s^2, not counts");
    DigestOptions reading = digest_options(o.input);
    reading.averages = false;  // the Allan deviation alone: each dwell is dropped once added
    RecordingDigest digest = digest_on_two_threads(o.recording, reading);
    print_warnings(digest.recording.warnings);
    if (!digest.allan) throw std::runtime_error(digest.allan_unavailable);
    print_warnings({digest.allan_warning()});  // gaps in the dwells
    return {digest.recording.source, digest.samples, std::move(*digest.allan), std::nullopt};
  }
  const RawInput in = read_input(o.recording, input_options(o.input));
  print_warnings(in.warnings);
  StaticNoiseOptions options;
  if (o.counts_per_g > 0) {
    if (in.units != InputUnits::counts)
      throw CLI::ValidationError("--counts-per-g", o.recording + " was read as " +
                                                       std::string(to_string(in.units)) + " (" +
                                                       in.units_how + "), not counts");
    options.counts_per_g = o.counts_per_g;
  }
  StaticNoise noise = static_noise(in, options);
  if (noise.allan.gaps.too_much())
    print_warnings({in.source + ": " + noise.allan.gaps.warning(kStaticIntervals)});
  NoiseSource source{in.source, noise.samples, std::move(noise.allan), std::nullopt};
  source.raw = std::move(noise);  // its curves moved out above: how they were read, alone
  return source;
}

json static_json(const StaticNoise& n) {
  const Vec3& k = n.ug_per_unit;
  return {{"intervals_how", n.intervals_how},
          {"static_samples", n.samples},
          {"longest_s", n.longest_s},
          {"units_how", n.units_how},
          {"ug_per_input_unit", json::array({k[0], k[1], k[2]})}};
}

// The time missing inside the static samples' stretches, or claimed beyond their stamps
// (DwellGaps); `too_much`: no wander is to be given to the fits from these curves.
json gaps_json(const DwellGaps& g) {
  return {{"missing_s", g.missing_s()},
          {"beyond_stamps_s", g.beyond_stamps_s()},
          {"spanned_s", g.spanned_s},
          {"count", g.count},
          {"missing_share", g.missing_share()},
          {"mismatch_share", g.mismatch_share()},
          {"too_much", g.too_much()}};
}

json gauss_markov_json(const GaussMarkovAllanFit& f, double curve_end_s) {
  json j = {{"wander_seen", f.wander_seen},
            {"wander_deviance", f.wander_deviance},
            {"tau_s", f.tau_s},
            {"tau_min_s", f.tau_min_s},
            {"tau_max_s", f.tau_open_above ? json(nullptr) : json(f.tau_max_s)},
            {"tau_bounded", f.tau_bounded},
            // The floor the fits take where the curves do not show the wander turn over (0: none).
            {"tau_floor_s", wander_tau_floor_s(f, curve_end_s)},
            {"short_correlation", f.short_correlation},
            {"deviance_per_dof", f.deviance_per_dof},
            {"describes_curves", f.describes_curves},
            {"worst_departure",
             {{"axis", std::string(1, "xyz"[f.worst_departure.axis])},
              {"tau_s", f.worst_departure.tau_s},
              {"ratio", f.worst_departure.ratio},
              {"deviance", f.worst_departure.deviance}}}};
  static const std::array<const char*, 3> axis_names{"x", "y", "z"};
  for (std::size_t a = 0; a < f.q.size() && a < 3; ++a) {
    j["axes"][axis_names[a]] = {{"q_ug", f.q[a]}, {"noise_density_ug_rthz", f.white_density[a]}};
    if (f.short_correlation) j["axes"][axis_names[a]]["short_correlation_q_ug"] = f.short_q[a];
    if (a < f.q_min.size()) {
      j["axes"][axis_names[a]]["q_min_ug"] = f.q_min[a];
      j["axes"][axis_names[a]]["q_max_ug"] = std::isfinite(f.q_max[a]) ? json(f.q_max[a]) : json();
    }
  }
  return j;
}

std::string per_axis(const std::vector<double>& v, const char* unit) {
  std::string s;
  for (std::size_t a = 0; a < v.size() && a < 3; ++a)
    s += std::string(a ? ", " : "") + "xyz"[a] + " " + diagnosis::fmt("%.3g", v[a]) + " " + unit;
  return s;
}

// "2.71-3.36 ug" or "2.71 ug and beyond": the sizes the curves allow.
std::string size_range_text(double lo, double hi) {
  return diagnosis::fmt("%.3g", lo) +
         (std::isfinite(hi) ? "-" + diagnosis::fmt("%.3g", hi) + " ug" : " ug and beyond");
}

// "x 3.02 ug (2.71-3.36), y ...": each axis's wander with the sizes the curves allow.
std::string sizes_with_ranges(const GaussMarkovAllanFit& f) {
  if (f.q_min.size() != f.q.size()) return per_axis(f.q, "ug");
  std::string s;
  for (std::size_t a = 0; a < f.q.size() && a < 3; ++a)
    s += std::string(a ? ", " : "") + "xyz"[a] + " " + diagnosis::fmt("%.3g", f.q[a]) + " ug (" +
         size_range_text(f.q_min[a], f.q_max[a]) + ")";
  return s;
}

// The samples' own correlation over about a sample period: what a dwell mean sees of it.
std::string short_correlation_words(const GaussMarkovAllanFit& f) {
  return "Gauss-Markov wander: none seen. The samples are correlated over about " +
         seconds_text(f.tau_s) + " s (this recording allows up to " + seconds_text(f.tau_max_s) +
         " s; a Gauss-Markov of " + per_axis(f.short_q, "ug") +
         " at that time fits it): the unit's output filter or decimation, not a bias wander. "
         "Dwell means see it as white noise, with the white noise beside it " +
         per_axis(f.white_density, "ug/sqrt(Hz)") +
         " (the noise density to give `standcal design`)";
}

// This recording as the fits and standcald take it, read as this command read it: "FILE
// --unit-static-rate-hz 10", and standcald's "unit.static_recording with
// unit.static_recording_input {"rate_hz":10}".
struct RecordingToGive {
  std::string args;
  std::string standcald;
};
RecordingToGive recording_to_give(const NoiseOptions& o) {
  const std::string keys = unit_static_reading_keys(o.input);
  return {o.recording + unit_static_reading_args(o.input),
          "unit.static_recording" +
              (keys.empty() ? std::string() : " with unit.static_recording_input " + keys)};
}

// Who else takes the recording so, and standcald's spelling of it (its runs' fits take it too).
std::string taken_too_words(const RecordingToGive& recording) {
  return " (any method but paper-sequential; import and certificate take it too; standcald: " +
         recording.standcald + ")";
}

// Curves that show no wander and reach the fits' shortest correlation time bound the wander a
// fit's sigmas allow for (take_wander_curves): how to give them.
std::string bound_words(const GaussMarkovAllanFit& f, double curve_end_s, const DwellGaps& gaps,
                        const RecordingToGive& recording) {
  if (!f.describes_curves || gaps.too_much() || curve_end_s < shortest_model_tau_s({})) return "";
  return "\nthe fits take this recording as the unit's: standcal fit RECORDING "
         "--unit-static-recording " +
         recording.args + taken_too_words(recording) +
         ", where it bounds the wander the fit's sigmas allow for";
}

// Curves that see a wander they do not pin put a floor under its correlation time, which the
// fits take from the recording itself (wander_tau_floor_s, take_tau_floor): how to give it.
std::string floor_words(const GaussMarkovAllanFit& f, double curve_end_s, const DwellGaps& gaps,
                        const RecordingToGive& recording) {
  const double floor_s = wander_tau_floor_s(f, curve_end_s);
  if (gaps.too_much() || !(floor_s > shortest_model_tau_s({}))) return "";
  return "\nthe fits take this recording as a floor of " + seconds_text(floor_s) +
         " s under the unit's correlation time: standcal fit RECORDING --unit-static-recording " +
         recording.args + taken_too_words(recording) +
         ", where the run shows the wander at those times";
}

// What the Allan curves say of the unit's correlation time, and how to give it to the fits
// (one calibration run cannot pin it: docs/calibration.md, "The correlation time, given").
std::string gauss_markov_words(const std::optional<GaussMarkovAllanFit>& f, double curve_end_s,
                               const DwellGaps& gaps, const RecordingToGive& recording) {
  if (!f) return "Gauss-Markov wander: the curves are too short to fit one (fewer than 5 octaves)";
  if (f->short_correlation) return short_correlation_words(*f);
  if (!f->wander_seen)
    return "Gauss-Markov wander: none seen up to " + seconds_text(curve_end_s) + " s" +
           (f->describes_curves ? " (white noise explains the curves)" : "") +
           bound_words(*f, curve_end_s, gaps, recording);
  const std::string s =
      "Gauss-Markov wander (white noise and one wander fitted to the three curves, "
      "one correlation time): steady-state sigma " +
      sizes_with_ranges(*f) + " (the sizes this recording allows)";
  const std::string how_long = " (its curves end at " + seconds_text(curve_end_s) +
                               " s; a static recording of about 100 x the correlation time "
                               "pins it)";
  if (f->tau_open_above)
    return s + "; correlation time not pinned: this recording allows " +
           seconds_text(f->tau_min_s) + " s and beyond" + how_long +
           floor_words(*f, curve_end_s, gaps, recording);
  if (!f->tau_bounded)  // the range reaches down to the shortest averaging time
    return s + "; correlation time not pinned: this recording allows up to " +
           seconds_text(f->tau_max_s) + " s" + how_long;
  const std::string lo = seconds_text(f->tau_min_s), hi = seconds_text(f->tau_max_s);
  const std::string found = s + "; correlation time " + seconds_text(f->tau_s) +
                            " s (this recording allows " + lo + "-" + hi + " s)";
  if (!f->describes_curves)
    return found +
           ", but the model does not describe the curves (below): no range to give "
           "the fits from them";
  if (gaps.too_much())
    return found + ", but the static samples' time stamps and their sample periods disagree by " +
           diagnosis::fmt("%.3g", 100 * gaps.mismatch_share()) +
           " % of their span (the warning above), so the curves may show the wrong correlation "
           "times: no range to give the fits from them";
  if (!curves_show_turnover(f->tau_max_s, curve_end_s))
    return found +
           ", not pinned: its curves end before the slowest of those turns over (a wander's "
           "Allan peak lies near 1.9 x its correlation time), and the sizes above are those at " +
           seconds_text(f->tau_s) + " s, too small at the slow end" + how_long +
           floor_words(*f, curve_end_s, gaps, recording);
  const std::optional<WanderToGive> give = wander_to_give(*f, curve_end_s);
  if (!give) return found;  // not reached: seen, bounded and describing the curves
  return found + "\ngive the unit's wander to the fits: standcal fit --bias-instability-ug " +
         diagnosis::fmt("%.3g", give->q) + " --bias-instability-tau-s " + lo +
         " --bias-instability-tau-max-s " + hi +
         " (standcald: unit.bias_instability_ug, unit.bias_instability_tau_s and "
         "unit.bias_instability_tau_max_s; the size is the largest axis's, which this "
         "recording allows at " +
         size_range_text(give->q_min, give->q_max) +
         ": a longer one narrows that); or give this recording itself, which weighs each "
         "axis with its own size: standcal fit RECORDING --unit-static-recording " +
         recording.args + " (standcald: " + recording.standcald +
         "). One calibration run "
         "cannot pin the correlation time, nor the size of a wander it seldom shows, and too "
         "short a tau or too small a size makes the biases' sigmas too small. The averaging "
         "time of the bias-instability floor above is not the correlation time (a Gauss-Markov "
         "wander's Allan peak lies near 1.9 x it). A stand calibration recording that holds "
         "one position as long as this one (a warm-up dwell) gives its fits this wander by "
         "itself.";
}

void run_noise(const NoiseOptions& o) {
  const NoiseSource source = read_noise_source(o);
  const DwellAllan& allan = source.allan;
  const double tau0 = allan.sample_period_s;
  static const std::array<const char*, 3> axis_names{"x", "y", "z"};
  const auto& curves = allan.curves;
  const auto& figures = allan.figures;
  if (!o.curve_out.empty()) {
    std::ostringstream out;
    out << "tau_s,adev_x_ug,adev_y_ug,adev_z_ug\n";
    for (std::size_t i = 0; i < curves[0].size(); ++i)
      out << curves[0][i].tau_s << "," << curves[0][i].deviation << "," << curves[1][i].deviation
          << "," << curves[2][i].deviation << "\n";
    write_file_atomically(o.curve_out, out.str(), "the Allan curve");
  }
  if (!o.plot_out.empty()) {
    std::vector<report::AxisAllan> axes;
    for (int a = 0; a < 3; ++a) axes.push_back({axis_names[a], curves[a], figures[a]});
    plot::write_svg(report::allan_figure(axes, source.name), o.plot_out);
    std::fprintf(stderr, "Allan deviation plot written to %s\n", o.plot_out.c_str());
  }
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  const std::optional<GaussMarkovAllanFit> wander =
      fit_gauss_markov_allan({curves[0], curves[1], curves[2]}, tau0);
  const double curve_end_s = curves_end_s({curves[0], curves[1], curves[2]});
  if (o.json) {
    json j = {{"recording", o.recording}, {"sample_period_s", tau0}, {"segments", allan.segments}};
    for (int a = 0; a < 3; ++a) {
      json curve = json::array();
      for (const auto& p : curves[a])
        curve.push_back({{"tau_s", p.tau_s}, {"adev_ug", p.deviation}});
      j["axes"][axis_names[a]] = {{"noise_density_ug_rthz", opt(figures[a].white_density)},
                                  {"bias_instability_ug", opt(figures[a].bias_instability)},
                                  {"bias_instability_tau_s", figures[a].bias_instability_tau_s},
                                  {"random_walk_ug_rts", opt(figures[a].random_walk)},
                                  {"allan_deviation", curve}};
    }
    j["static"] = source.raw ? static_json(*source.raw) : json(nullptr);
    j["gauss_markov"] = wander ? gauss_markov_json(*wander, curve_end_s) : json(nullptr);
    j["gaps"] = gaps_json(allan.gaps);
    std::cout << json_text(j) << "\n";
    return;
  }
  std::printf("%s: %zu samples every %.4g s in %zu static segment(s)\n", o.recording.c_str(),
              source.samples, tau0, allan.segments);
  if (source.raw)
    std::printf("static samples: %s; the longest stretch %.4g s\nread as %s\n",
                source.raw->intervals_how.c_str(), source.raw->longest_s,
                source.raw->units_how.c_str());
  std::printf("  %-4s %22s %26s %22s\n", "axis", "noise density ug/rtHz",
              "bias instability ug (tau)", "random walk ug/rt(s)");
  auto cell = [](const std::optional<double>& v) {
    char b[32];
    if (v)
      std::snprintf(b, sizeof b, "%.3g", *v);
    else
      std::snprintf(b, sizeof b, "not seen");
    return std::string(b);
  };
  for (int a = 0; a < 3; ++a) {
    char tau[32] = "";
    if (figures[a].bias_instability)
      std::snprintf(tau, sizeof tau, " (%.3g s)", figures[a].bias_instability_tau_s);
    std::printf("  %-4s %22s %26s %22s\n", axis_names[a], cell(figures[a].white_density).c_str(),
                (cell(figures[a].bias_instability) + tau).c_str(),
                cell(figures[a].random_walk).c_str());
  }
  if (wander && wander->short_correlation)
    std::printf(
        "(the samples are correlated: give `standcal design` the white noise a dwell "
        "mean sees, below)\n");
  else if (wander && wander->wander_seen)
    // The -1/2 slope read at 1 s carries some of a wander of seconds to minutes.
    std::printf(
        "the wander below raises the noise density read at 1 s; the white noise fitted beside "
        "it is x %.3g, y %.3g, z %.3g ug/rtHz, the one to give `standcal design "
        "--noise-density-ug-rthz N` with the wander\n",
        wander->white_density[0], wander->white_density[1], wander->white_density[2]);
  else
    std::printf("use the noise density with `standcal design ... --noise-density-ug-rthz N`\n");
  std::printf("%s\n",
              gauss_markov_words(wander, curve_end_s, allan.gaps, recording_to_give(o)).c_str());
  if (wander && !wander->describes_curves) {
    const GaussMarkovAllanFit::Departure& d = wander->worst_departure;
    const bool white_alone = !wander->wander_seen && !wander->short_correlation;
    std::printf(
        "the curves depart from %s: their scatter about the fit is %.3g x what their clusters "
        "allow, most on %c at %s s (%.3g x the model's deviation): motion left in the static "
        "intervals, or a noise process the model lacks; read the figures above as a summary "
        "and the curve itself (--plot)\n",
        white_alone ? "white noise alone" : "white noise and one correlation time",
        wander->deviance_per_dof, "xyz"[d.axis], seconds_text(d.tau_s).c_str(), d.ratio);
  }
}

void add_noise_command(CLI::App& app) {
  auto no = std::make_shared<NoiseOptions>();
  CLI::App* noise = app.add_subcommand(
      "noise", "Allan deviation of a static recording: noise density, bias instability");
  noise
      ->add_option("recording", no->recording,
                   "a static recording: standcal's (its dwells pooled), imu_tk text or delimited "
                   "text (the static intervals found pooled)")
      ->required();
  add_input_options(noise, no->input);
  noise
      ->add_option("--counts-per-g", no->counts_per_g,
                   "scale of counts, for a unit held in one orientation (with several, the "
                   "norm fit finds it)")
      ->check(cli_checks::kPositive);
  noise->add_flag("--json", no->json, "machine-readable output");
  noise->add_option("--curve", no->curve_out,
                    "write the Allan deviation curve as CSV (tau_s, adev per axis in ug)");
  noise->add_option("--plot", no->plot_out,
                    "draw the Allan deviation of each axis (log-log, SVG) to FILE");
  noise->callback([no] { run_noise(*no); });
}

}  // namespace

static const bool noise_command_registered = register_command_group(add_noise_command);

}  // namespace standcal::cli
