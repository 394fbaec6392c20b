#include "report/diagnosis/diagnosis_report.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "report/diagnosis/svg_compact.hpp"
#include "report/noise/allan_figure.hpp"

namespace standcal::report {

namespace {

// A baseline residual beyond this many standard errors marks its position as carrying the
// mismatch (the same 3-sigma rule as calib's `located`).
constexpr double kLocatedSigma = 3.0;

// What the page shows instead of a number that is not finite.
constexpr const char* kNoNumber = "n/a";

// Every number on the page goes through here: a value that is not finite (a term the data
// cannot identify, a temperature never recorded, a z without a standard error) is never
// printed as "nan" or "inf".
std::string number(const char* format, double v) {
  if (!std::isfinite(v)) return kNoNumber;
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

bool non_finite_word(std::string word) {
  for (char& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return word == "nan" || word == "inf" || word == "infinity";
}

// Text written by calib (summary sentences, locations, reasons) carries numbers printed
// there: one that is not finite ("nan", "-inf") is shown as the page's own numbers are.
std::string calib_text(const std::string& s) {
  std::string out;
  std::size_t i = 0;
  while (i < s.size()) {
    std::size_t j = i;
    while (j < s.size() && word_char(s[j])) ++j;
    if (j == i) {
      out += s[i++];
      continue;
    }
    if (non_finite_word(s.substr(i, j - i))) {
      if (!out.empty() && (out.back() == '+' || out.back() == '-')) out.pop_back();
      out += kNoNumber;
    } else {
      out.append(s, i, j - i);
    }
    i = j;
  }
  return html_escape(out);
}

// The temperature the diagnosis references temperature terms to (calib's rule: the
// recording's temp_ref_c, else its first measured temperature).
double temperature_reference_c(const Recording& rec) {
  if (rec.temp_ref_c) return *rec.temp_ref_c;
  for (const RecordingSample& s : rec.samples)
    if (std::isfinite(s.temp_c)) return s.temp_c;
  return 0.0;
}

// The findings that are terms of the catalog the simulator models. A finding outside it
// (mounting_misalignment_large: a size of what the baseline fits anyway) has no signature
// left in the residuals to draw.
std::vector<ExtraEffect> findings_as_effects(const Diagnosis& d) {
  std::vector<ExtraEffect> effects;
  for (const Finding& f : d.findings)
    if (!extra_effect_unit(f.effect).empty())
      effects.push_back({f.effect, f.axis, f.value, f.tau_s, f.phase_deg});
  return effects;
}

// Stand effects act through the geometry: the stand sits at the reading (the commanded
// angle), the unit at the true angle = reading + angle-sensor error, on a base whose level
// has drifted by the dwell's mid-time (linear in time, so the dwell mean).
Vec3 stand_effect_g(const std::vector<ExtraEffect>& effects, const PositionAverage& p) {
  const double a1 = p.alpha1_cmd_deg, a2 = p.alpha2_cmd_deg;
  const double true1 = a1 + angle_sensor_error_deg(effects, 1, a1),
               true2 = a2 + angle_sensor_error_deg(effects, 2, a2);
  StandErrors drifted;
  const Vec3 level = level_drift_rad(effects, 0.5 * (p.t_start_s + p.t_end_s));
  drifted.levelling_x_rad = level.x();
  drifted.levelling_z_rad = level.z();
  return true_up_vector(true1 * kDegToRad, true2 * kDegToRad, p.mount, drifted) -
         up_vector(a1 * kDegToRad, a2 * kDegToRad, p.mount);
}

// Each position's dwell mean of what the findings add to J (g), sample by sample with
// the parametrisations of the simulator (model.md's catalog).
std::vector<Vec3> findings_effect_per_position_g(const Diagnosis& d, const Recording& rec,
                                                 const std::vector<PositionAverage>& avg) {
  std::vector<Vec3> sum(avg.size(), Vec3::Zero());
  const std::vector<ExtraEffect> effects = findings_as_effects(d);
  if (effects.empty()) return sum;
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < avg.size(); ++k) index[avg[k].pos] = k;
  std::vector<double> count(avg.size(), 0);
  const double temp_ref_c = temperature_reference_c(rec);
  const double warmup_end = warmup_end_s(rec);  // a warm-up's rows are not in the means
  for (const RecordingSample& s : rec.samples) {
    const auto it = index.find(s.pos);
    if (it == index.end() || is_warmup_row(s, warmup_end)) continue;
    const PositionAverage& p = avg[it->second];
    const Vec3 J = s.f_mps2 / rec.g_local_mps2;
    const double temp_delta_c = std::isfinite(s.temp_c) ? s.temp_c - temp_ref_c : 0.0;
    for (const ExtraEffect& e : effects) {
      const int axis = extra_effect_output_axis(e);
      if (axis >= 0 && axis < 3)
        sum[it->second][axis] +=
            extra_effect_output_g(e, J, s.t_s, temp_delta_c, p.approach, s.t_s - p.t_arrive_s);
    }
    count[it->second] += 1;
  }
  for (std::size_t k = 0; k < avg.size(); ++k) {
    if (count[k] > 0) sum[k] /= count[k];
    sum[k] += stand_effect_g(effects, avg[k]);
  }
  return sum;
}

// White, as the diagnosis's own residuals are before its noise model decorrelates them.
FitResult refit(const Diagnosis& d, const std::vector<PositionAverage>& avg) {
  return d.method == "full" ? fit_full_vector(avg, white_noise_weighting())
                            : fit_invariant_joint(avg, white_noise_weighting());
}

std::vector<double> to_ug(const Eigen::VectorXd& v_g) {
  std::vector<double> out;
  for (Eigen::Index i = 0; i < v_g.size(); ++i) out.push_back(v_g[i] / kUg);
  return out;
}

// ---- figures -------------------------------------------------------------------------

struct Axis {  // one x variable of the residual panels
  std::string name, label;
  double (*value)(const ResidualPoint&, int component);
  bool time_ordered = false;  // draw the prediction as a line through time
};

double alpha1_of(const ResidualPoint& p, int) { return p.alpha1_deg; }
double alpha2_of(const ResidualPoint& p, int) { return p.alpha2_deg; }
double up_of(const ResidualPoint& p, int c) { return p.up[c]; }
double time_of(const ResidualPoint& p, int) { return p.t_mid_s; }
double temp_of(const ResidualPoint& p, int) { return p.temp_c; }

// Residuals against temperature say something only when the temperature moved: at least
// kMinTemperatureSpread_c between positions (a climatic chamber, a warming unit).
constexpr double kMinTemperatureSpread_c = 0.05;

bool temperature_varies(const std::vector<ResidualPoint>& points) {
  double lo = 1e300, hi = -1e300;
  for (const ResidualPoint& p : points) {
    if (!std::isfinite(p.temp_c)) return false;
    lo = std::min(lo, p.temp_c);
    hi = std::max(hi, p.temp_c);
  }
  return hi - lo >= kMinTemperatureSpread_c;
}

bool located(const ResidualPoint& p, std::size_t c) {
  return p.before_sigma_ug[c] > 0 &&
         std::abs(p.before_ug[c]) > kLocatedSigma * p.before_sigma_ug[c];
}

// Shaded spans around the positions that carry the mismatch on this component: their
// dwell on the time axis, a narrow band around their value on the others.
std::vector<plot::Span> located_spans(const std::vector<ResidualPoint>& points, std::size_t c,
                                      const Axis& axis) {
  double lo = 1e300, hi = -1e300;
  for (const ResidualPoint& p : points) {
    lo = std::min(lo, axis.value(p, static_cast<int>(c)));
    hi = std::max(hi, axis.value(p, static_cast<int>(c)));
  }
  const double half_width = hi > lo ? 0.008 * (hi - lo) : 0.5;
  std::vector<plot::Span> spans;
  for (const ResidualPoint& p : points) {
    if (!located(p, c)) continue;
    if (axis.time_ordered) {
      spans.push_back({std::min(p.t_start_s, p.t_mid_s - half_width),
                       std::max(p.t_end_s, p.t_mid_s + half_width)});
    } else {
      const double x = axis.value(p, static_cast<int>(c));
      spans.push_back({x - half_width, x + half_width});
    }
  }
  return spans;
}

bool any_prediction(const std::vector<ResidualPoint>& points) {
  for (const ResidualPoint& p : points)
    for (double v : p.predicted_ug)
      if (v != 0) return true;
  return false;
}

plot::Panel residual_panel(const std::vector<ResidualPoint>& points, std::size_t c,
                           const std::string& component, const Axis& axis) {
  plot::Panel panel;
  const std::string output = component == "L" ? "invariant projection L" : component + " output";
  panel.title =
      output + ": residuals vs " + axis.name + " (shaded: beyond 3 sigma in the baseline)";
  panel.x_label = axis.label;
  panel.y_label = "residual (ug)";
  panel.y_reference = 0.0;
  std::vector<const ResidualPoint*> order;
  for (const ResidualPoint& p : points) order.push_back(&p);
  std::sort(order.begin(), order.end(), [&](const ResidualPoint* a, const ResidualPoint* b) {
    return axis.value(*a, static_cast<int>(c)) < axis.value(*b, static_cast<int>(c));
  });
  plot::Series before{"before (baseline model)", {}, {}, {}, plot::SeriesStyle::points};
  plot::Series after{"after (with the findings)", {}, {}, {}, plot::SeriesStyle::points};
  plot::Series predicted{
      "predicted by the findings",
      {},
      {},
      {},
      axis.time_ordered ? plot::SeriesStyle::points_and_line : plot::SeriesStyle::points};
  for (const ResidualPoint* p : order) {
    const double x = axis.value(*p, static_cast<int>(c));
    before.x.push_back(x);
    before.y.push_back(p->before_ug[c]);
    before.y_sigma.push_back(p->before_sigma_ug[c]);
    after.x.push_back(x);
    after.y.push_back(p->after_ug[c]);
    after.y_sigma.push_back(p->after_sigma_ug[c]);
    predicted.x.push_back(x);
    predicted.y.push_back(p->predicted_ug[c]);
  }
  panel.series = {before, after};
  if (any_prediction(points)) panel.series.push_back(predicted);
  panel.highlight = located_spans(points, c, axis);
  return panel;
}

}  // namespace

std::vector<std::string> component_names(const Diagnosis& d) {
  if (d.method == "full") return {"x", "y", "z"};
  return {"L"};
}

std::vector<ResidualPoint> residual_points(const Diagnosis& d, const Recording& rec) {
  const std::vector<PositionAverage> avg = average_positions(rec);
  if (d.baseline.residuals.size() != avg.size() || d.final_fit.residuals.size() != avg.size()) {
    throw std::runtime_error(
        "report: the diagnosis has " + std::to_string(d.baseline.residuals.size()) +
        " positions but the recording " + rec.source + " has " + std::to_string(avg.size()) +
        "; it was not computed from this recording");
  }
  // The findings' effects removed from the averages, refitted by the baseline's estimator:
  // what stays in the residuals is the part of their signature the parameters cannot absorb.
  std::vector<Eigen::VectorXd> predicted_g(avg.size());
  if (!findings_as_effects(d).empty()) {
    const std::vector<Vec3> effect_g = findings_effect_per_position_g(d, rec, avg);
    std::vector<PositionAverage> corrected = avg;
    for (std::size_t k = 0; k < avg.size(); ++k) corrected[k].mean_g -= effect_g[k];
    const FitResult without = refit(d, corrected);
    for (std::size_t k = 0; k < avg.size(); ++k)
      predicted_g[k] = d.baseline.residuals[k].residual_g - without.residuals[k].residual_g;
  }
  std::vector<ResidualPoint> points;
  for (std::size_t k = 0; k < avg.size(); ++k) {
    const PositionAverage& a = avg[k];
    ResidualPoint p;
    p.pos = a.pos;
    p.alpha1_deg = a.alpha1_cmd_deg;
    p.alpha2_deg = a.alpha2_cmd_deg;
    p.t_start_s = a.t_start_s;
    p.t_end_s = a.t_end_s;
    p.t_mid_s = 0.5 * (a.t_start_s + a.t_end_s);
    p.temp_c = a.temp_mean_c;
    p.up = a.up();
    p.before_ug = to_ug(d.baseline.residuals[k].residual_g);
    p.before_sigma_ug = to_ug(d.baseline.residuals[k].sigma_g);
    p.after_ug = to_ug(d.final_fit.residuals[k].residual_g);
    p.after_sigma_ug = to_ug(d.final_fit.residuals[k].sigma_g);
    p.predicted_ug = predicted_g[k].size() == 0 ? std::vector<double>(p.before_ug.size(), 0.0)
                                                : to_ug(predicted_g[k]);
    points.push_back(p);
  }
  return points;
}

std::vector<plot::Figure> residual_figures(const Diagnosis& d,
                                           const std::vector<ResidualPoint>& points) {
  const std::vector<std::string> names = component_names(d);
  std::vector<plot::Figure> figures;
  if (points.empty()) return figures;
  for (std::size_t c = 0; c < names.size() && c < points.front().before_ug.size(); ++c) {
    std::vector<Axis> axes;
    if (d.method == "norm") {
      // No stand angles: the orientation is gravity's direction in the sensor frame.
      for (const char* a : {"x", "y", "z"})
        axes.push_back({std::string("u_") + a,
                        std::string("u_") + a + " (g): gravity along the " + a + " axis", up_of});
    } else {
      axes = {{"alpha1", "alpha1 (deg), outer axis", alpha1_of},
              {"alpha2", "alpha2 (deg), inner axis", alpha2_of}};
      if (names[c] != "L")
        axes.push_back({"u_" + names[c],
                        "u_" + names[c] + " (g): gravity along the " + names[c] + " axis", up_of});
    }
    axes.push_back({"time", "time since the run started (s)", time_of, true});
    if (temperature_varies(points))
      axes.push_back({"temperature", "unit temperature (degC)", temp_of});
    plot::Figure fig;
    fig.panel_height_px = 280;
    for (const Axis& axis : axes) fig.panels.push_back(residual_panel(points, c, names[c], axis));
    figures.push_back(fig);
  }
  return figures;
}

std::vector<plot::Figure> settling_figures(const Diagnosis& d, const Recording& rec) {
  std::vector<plot::Figure> figures;
  std::vector<PositionAverage> avg;
  for (const Finding& f : d.findings) {
    if (f.effect != "settling_transient" || f.tau_s <= 0) continue;
    if (avg.empty()) avg = average_positions(rec);
    const int axis = extra_effect_output_axis({f.effect, f.axis, f.value, f.tau_s});
    std::map<int, std::size_t> index;
    for (std::size_t k = 0; k < avg.size(); ++k) index[avg[k].pos] = k;
    // The finding's shape de-meaned per dwell, as the position mean absorbs its average.
    std::vector<double> shape_sum(avg.size(), 0), shape_n(avg.size(), 0);
    double longest_s = 0;
    const double warmup_end = warmup_end_s(rec);  // a warm-up's rows are not in the means
    for (const RecordingSample& s : rec.samples) {
      if (is_warmup_row(s, warmup_end)) continue;
      const std::size_t k = index.at(s.pos);
      const double since = s.t_s - avg[k].t_arrive_s;
      shape_sum[k] += std::exp(-since / f.tau_s);
      shape_n[k] += 1;
      longest_s = std::max(longest_s, since);
    }
    const double bin_s = std::max(0.25, longest_s / 60.0);
    const auto n_bins = static_cast<std::size_t>(longest_s / bin_s) + 1;
    std::vector<double> r_sum(n_bins, 0), r_sq(n_bins, 0), p_sum(n_bins, 0), n(n_bins, 0);
    for (const RecordingSample& s : rec.samples) {
      if (is_warmup_row(s, warmup_end)) continue;
      const std::size_t k = index.at(s.pos);
      const double since = s.t_s - avg[k].t_arrive_s;
      if (since < 0) continue;
      const auto b = std::min(n_bins - 1, static_cast<std::size_t>(since / bin_s));
      const double r_ug = (s.f_mps2[axis] / rec.g_local_mps2 - avg[k].mean_g[axis]) / kUg;
      r_sum[b] += r_ug;
      r_sq[b] += r_ug * r_ug;
      p_sum[b] += f.value * (std::exp(-since / f.tau_s) - shape_sum[k] / shape_n[k]);
      n[b] += 1;
    }
    plot::Series data{
        "samples minus their position mean (bin mean)", {}, {}, {}, plot::SeriesStyle::points};
    plot::Series predicted{"predicted: " + number("%+.1f", f.value) + " ug * exp(-t/" +
                               number("%.0f", f.tau_s) + " s)",
                           {},
                           {},
                           {},
                           plot::SeriesStyle::line};
    for (std::size_t b = 0; b < n_bins; ++b) {
      if (n[b] < 2) continue;
      const double x = (static_cast<double>(b) + 0.5) * bin_s;
      const double mean = r_sum[b] / n[b];
      const double var = std::max(0.0, r_sq[b] / n[b] - mean * mean);
      data.x.push_back(x);
      data.y.push_back(mean);
      data.y_sigma.push_back(std::sqrt(var / (n[b] - 1)));
      predicted.x.push_back(x);
      predicted.y.push_back(p_sum[b] / n[b]);
    }
    plot::Panel panel;
    panel.title =
        f.axis + " output: raw samples inside each dwell vs time since arrival (all positions)";
    panel.x_label = "time since the stand arrived in position (s)";
    panel.y_label = "within-dwell residual (ug)";
    panel.y_reference = 0.0;
    panel.series = {data, predicted};
    plot::Figure fig;
    fig.panels.push_back(panel);
    figures.push_back(fig);
  }
  return figures;
}

namespace {

std::string residual_cells(const std::vector<double>& v, const std::vector<double>& sigma) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double z = sigma[i] > 0 ? v[i] / sigma[i] : kNaN;
    const bool hot = std::abs(z) > kLocatedSigma;
    s += std::string("<td") + (hot ? " class=\"hot\"" : "") + ">" + number("%+.1f", v[i]) + " (" +
         number("%+.1f", z) + ")</td>";
  }
  return s;
}

// A heading and what it heads, or nothing when there is nothing under it.
std::string section(const std::string& heading, const std::string& body) {
  return body.empty() ? "" : "<h2>" + heading + "</h2>\n" + body;
}

std::string list_items(const std::vector<std::string>& items) {
  if (items.empty()) return "";
  std::string h = "<ul>";
  for (const std::string& s : items) h += "<li>" + calib_text(s) + "</li>";
  return h + "</ul>\n";
}

std::string findings_table(const Diagnosis& d) {
  if (d.findings.empty()) return "<p>No finding.</p>\n";
  std::string h =
      "<table><tr><th>effect</th><th>axis</th><th>value</th><th>sigma</th><th>unit</th>"
      "<th>tau (s)</th><th>chi2 gain</th><th>chi2/dof after</th><th>absorbed into</th></tr>";
  for (const Finding& f : d.findings)
    h += "<tr><td>" + html_escape(f.effect) + "</td><td>" + html_escape(f.axis) + "</td><td>" +
         number("%+.2f", f.value) + "</td><td>" + number("%.2f", f.sigma) + "</td><td>" +
         html_escape(f.unit) + "</td><td>" + (f.tau_s > 0 ? number("%.0f", f.tau_s) : "") +
         "</td><td>" + number("%.1f", f.delta_chi2) + "</td><td>" +
         (std::isfinite(f.chi2_dof_after) ? number("%.2f", f.chi2_dof_after) : "") + "</td><td>" +
         calib_text(f.absorbed_into) + "</td></tr>";
  return h + "</table>\n";
}

bool any_temperature(const std::vector<ResidualPoint>& points) {
  return std::any_of(points.begin(), points.end(),
                     [](const ResidualPoint& p) { return std::isfinite(p.temp_c); });
}

std::string residual_table(const Diagnosis& d, const std::vector<ResidualPoint>& points) {
  if (points.empty()) return "";
  const std::vector<std::string> names = component_names(d);
  const auto n = std::to_string(names.size());
  // A recording without temperature has no column for it rather than one of n/a.
  const bool temperature = any_temperature(points);
  std::string h =
      "<table><tr><th rowspan=2>pos</th><th rowspan=2>alpha1</th><th rowspan=2>alpha2</th>"
      "<th rowspan=2>t (s)</th>" +
      std::string(temperature ? "<th rowspan=2>T (degC)</th>" : "") + "<th colspan=" + n +
      ">before, ug (sigma)</th><th colspan=" + n + ">after, ug (sigma)</th></tr><tr>";
  for (int pass = 0; pass < 2; ++pass)
    for (const std::string& c : names) h += "<th>" + c + "</th>";
  h += "</tr>";
  for (const ResidualPoint& p : points)
    h += "<tr><td>" + std::to_string(p.pos) + "</td><td>" + number("%.1f", p.alpha1_deg) +
         "</td><td>" + number("%.1f", p.alpha2_deg) + "</td><td>" + number("%.0f", p.t_mid_s) +
         "</td>" + (temperature ? "<td>" + number("%.2f", p.temp_c) + "</td>" : "") +
         residual_cells(p.before_ug, p.before_sigma_ug) +
         residual_cells(p.after_ug, p.after_sigma_ug) + "</tr>";
  return h + "</table>\n";
}

std::string structure_table(const Diagnosis& d) {
  if (d.structure.empty()) return "";
  std::string h = "<table><tr><th>axis</th><th>against</th><th>z</th></tr>";
  for (const StructureTest& s : d.structure)
    h += "<tr><td>" + html_escape(s.axis) + "</td><td>" + html_escape(s.against) + "</td><td" +
         (std::abs(s.z) > kLocatedSigma ? " class=\"hot\"" : "") + ">" + number("%+.2f", s.z) +
         "</td></tr>";
  return h + "</table>\n";
}

// Why a candidate's numbers say nothing, or "" when they do. A value or sigma that is not
// finite, or no standard error at all, is not an estimate: the reader sees the reason,
// never the number (issue 15: a cross-coupling of 1.2e16 ug/g2 was printed).
std::string untestable_reason(const Diagnosis& d, const CandidateTest& c) {
  if (!c.testable)
    return c.reason.empty() ? "the programme cannot identify it" : calib_text(c.reason);
  if (!std::isfinite(c.value) || !std::isfinite(c.sigma))
    return "the fit cannot identify it (its estimate is not finite)";
  if (d.verdict == "insufficient_redundancy")
    return "the programme has no redundancy to test it (see the verdict)";
  if (!(c.sigma > 0)) return "not estimated (no standard error)";
  return "";
}

std::string candidate_row(const Diagnosis& d, const CandidateTest& c) {
  std::string h = "<tr><td>" + html_escape(c.effect) + "</td><td>" + html_escape(c.axis) + "</td>";
  const std::string why_not = untestable_reason(d, c);
  if (!why_not.empty()) return h + "<td colspan=6>not testable: " + why_not + "</td></tr>";
  return h + "<td>" + number("%+.2f", c.value) + "</td><td>" + number("%.2f", c.sigma) +
         "</td><td>" + html_escape(c.unit) + "</td><td>" + number("%.1f", c.delta_chi2) +
         "</td><td>" + number("%.1f", c.delta_bic) + "</td><td>" + number("%.1f", c.press_gain) +
         "</td></tr>";
}

std::string candidates_table(const Diagnosis& d) {
  if (d.candidates.empty()) return "";
  std::string h =
      "<table><tr><th>effect</th><th>axis</th><th>value</th><th>sigma</th><th>unit</th>"
      "<th>chi2 gain</th><th>BIC gain</th><th>held-out gain</th></tr>";
  for (const CandidateTest& c : d.candidates) h += candidate_row(d, c);
  return h + "</table>\n";
}

std::string proposed_table(const Diagnosis& d) {
  if (d.proposed_positions.empty()) return "";
  std::string h = "<table><tr><th>alpha1 (deg)</th><th>alpha2 (deg)</th><th>why</th></tr>";
  for (const ProposedPosition& p : d.proposed_positions)
    h += "<tr><td>" + number("%.0f", p.alpha1_deg) + "</td><td>" + number("%.0f", p.alpha2_deg) +
         "</td><td>" + calib_text(p.why) + "</td></tr>";
  return h + "</table>\n";
}

// The figures of one page, each inlined with its own id prefix (ids are unique per page).
class FigureBlocks {
 public:
  std::string operator()(const plot::Figure& fig) {
    const std::string id = "figure" + std::to_string(++count_);
    return "<figure id=\"" + id + "\">" + compact_svg(plot::render_svg_inline(fig, id)) +
           "</figure>\n";
  }

 private:
  int count_ = 0;
};

const char* const kResidualsIntro =
    "<p>Per output axis: each position's residual (ug, with its standard error as the bar) "
    "against the stand angles, the gravity component along the axis, time and temperature. "
    "<i>Before</i>: the baseline model; <i>after</i>: refitted with the findings. Shaded: the "
    "positions whose baseline residual is beyond 3 sigma (the located mismatch). <i>Predicted "
    "by the findings</i>: the residual pattern the found effects leave after the calibration "
    "parameters absorbed what they can.</p>\n";

std::string residuals_section(const Diagnosis& d, const std::vector<ResidualPoint>& points,
                              FigureBlocks& figure) {
  if (points.empty()) return "";
  std::string h = kResidualsIntro;
  if (!temperature_varies(points))
    h += "<p>The unit temperature was not recorded or stayed within " +
         number("%.2f", kMinTemperatureSpread_c) + " degC: no panel against temperature.</p>\n";
  for (const plot::Figure& fig : residual_figures(d, points)) h += figure(fig);
  return section("Residuals before and after", h);
}

// A recording without angles: the Allan deviation of its static intervals pooled, which
// the noise model reads each mean's standard error and the unit's grade from.
std::string allan_section(const Diagnosis& d, const Recording& rec, FigureBlocks& figure) {
  if (d.method != "norm") return "";
  const DwellAllan allan = dwell_allan(rec);
  std::vector<AxisAllan> axes;
  for (std::size_t a = 0; a < 3; ++a)
    axes.push_back({std::string(1, "xyz"[a]), allan.curves[a], allan.figures[a]});
  return section(
      "Noise: Allan deviation of the static intervals",
      "<p>" + std::to_string(allan.segments) +
          " intervals pooled, calibrated axes. Each interval mean's standard error is "
          "read off this curve at the interval's length, never below sigma/sqrt(n).</p>\n" +
          figure(allan_figure(axes, d.source)));
}

std::string settling_section(const Diagnosis& d, const Recording& rec, FigureBlocks& figure) {
  const std::vector<plot::Figure> settling = settling_figures(d, rec);
  if (settling.empty()) return "";
  std::string h =
      "<p>A transient of the same shape at every position is invisible in the per-position "
      "means; inside each dwell it shows as a decay after arrival.</p>\n";
  for (const plot::Figure& fig : settling) h += figure(fig);
  return section("Settling transient on the raw samples", h);
}

std::string page_head(const Diagnosis& d) {
  return "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>standcal diagnosis: " +
         html_escape(d.source) +
         "</title><style>body{font-family:sans-serif;max-width:70em}table{border-collapse:"
         "collapse;margin:0.5em 0}td,th{border:1px solid #999;padding:2px 6px;text-align:right}"
         ".hot{background:#f99}figure{margin:0.5em 0}svg{max-width:100%;height:auto}</style>"
         "</head><body>\n";
}

std::string verdict_block(const Diagnosis& d, std::size_t positions) {
  return "<h1>Model-mismatch diagnosis: " + html_escape(d.source) +
         "</h1>\n<p><b>Verdict: " + html_escape(d.verdict) + "</b> (baseline: " +
         (d.method == "full"   ? std::string("full-vector fit")
          : d.method == "norm" ? std::string("attitude-free norm fit, |f| = g")
                               : std::string("invariant joint fit")) +
         ", " + std::to_string(positions) + " positions)</p>\n" + list_items(d.summary);
}

}  // namespace

std::string diagnosis_html(const Diagnosis& d, const Recording& rec) {
  const std::vector<ResidualPoint> points = residual_points(d, rec);
  FigureBlocks figure;
  std::string h = page_head(d) + verdict_block(d, points.size());
  h += section("Where the mismatch is", list_items(d.located));
  h += section("Findings", findings_table(d));
  h += section("Proposed positions", proposed_table(d));
  h += residuals_section(d, points, figure);
  h += settling_section(d, rec, figure);
  h += allan_section(d, rec, figure);
  const std::string residuals = residual_table(d, points);
  h += section(
      "Residual table",
      residuals.empty() ? "" : "<p>Cells beyond 3 sigma are highlighted.</p>\n" + residuals);
  h += section("Structure tests (baseline residual trend, sigma units)", structure_table(d));
  h += section("Catalog candidates (first round, against the baseline)", candidates_table(d));
  h += section("Not tested", list_items(d.not_tested));
  return h + "</body></html>\n";
}

}  // namespace standcal::report
