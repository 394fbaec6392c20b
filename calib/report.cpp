#include "calib/report.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "calib/distributions.hpp"
#include "calib/text.hpp"

namespace standcal {

namespace {

using nlohmann::json;

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string format(const char* fmt, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, a);
  return buf;
}

std::string chi2_verdict(const FitResult& fit) {
  if (fit.redundancy <= 0)
    return "not testable: no redundancy (the fit passes through every position)";
  const double p = chi_square_upper_tail(fit.chi2, fit.redundancy);
  std::string text = format("%.2f", fit.chi2_dof) + " with " + std::to_string(fit.redundancy) +
                     " degrees of freedom (p = " + format("%.3f", p) + "): ";
  if (p < 0.001)
    return text +
           "the residuals are LARGER than the noise explains; the model "
           "misses something (run `standcal diagnose`)";
  if (p > 0.999)
    return text +
           "the residuals are smaller than the noise predicts; the standard "
           "errors may be overstated";
  return text + "consistent with the measured noise";
}

void append_parameters(std::string& out, const FitResult& fit) {
  out += "  parameter        value          1 sigma\n";
  for (int j = 0; j < kUnitParameterCount; ++j) {
    const ParameterEstimate& p = fit.unit[static_cast<std::size_t>(j)];
    char line[160];
    if (p.value) {
      std::snprintf(line, sizeof line, "  %-10s %+12.2f %-6s %10.2f\n",
                    std::string(kUnitParameterNames[static_cast<std::size_t>(j)]).c_str(),
                    *p.value * report_scale(j),
                    std::string(kUnitParameterUnits[static_cast<std::size_t>(j)]).c_str(),
                    *p.sigma * report_scale(j));
      out += line;
    } else {
      std::snprintf(line, sizeof line, "  %-10s   not observable\n",
                    std::string(kUnitParameterNames[static_cast<std::size_t>(j)]).c_str());
      out += line;
      out += "      (" + p.unobservable_reason + ")\n";
    }
  }
}

void append_residuals(std::string& out, const FitResult& fit, const ReportContext& ctx) {
  const bool per_axis = !fit.residuals.empty() && fit.residuals[0].residual_g.size() == 3;
  out += per_axis
             ? "\nResiduals per position and axis (ug; measured J minus the model):\n"
             : "\nResiduals per position (ug; invariant residual = u.J - 1 minus the model):\n";
  out += "  pos  alpha1    alpha2   mount  samples  axis  residual      sigma   res/sigma\n";
  for (std::size_t k = 0; k < fit.residuals.size(); ++k) {
    const PositionResidual& r = fit.residuals[k];
    const std::size_t samples = k < ctx.averages.size() ? ctx.averages[k].samples : 0;
    for (Eigen::Index c = 0; c < r.residual_g.size(); ++c) {
      char line[160];
      const char* axis = per_axis ? (c == 0 ? "x" : c == 1 ? "y" : "z") : "u";
      std::snprintf(line, sizeof line,
                    "  %3d %8.3f %9.3f   %s  %7zu   %s  %+9.3f  %9.3f   %+6.2f\n", r.pos,
                    r.alpha1_cmd_deg, r.alpha2_cmd_deg, mount_name(r.mount).c_str(), samples, axis,
                    r.residual_g[c] / kUg, r.sigma_g[c] / kUg, r.residual_g[c] / r.sigma_g[c]);
      out += line;
    }
  }
}

void append_strong_correlations(std::string& out, const FitResult& fit) {
  std::string list;
  for (int a = 0; a < kUnitParameterCount; ++a)
    for (int b = a + 1; b < kUnitParameterCount; ++b) {
      const double c = fit.correlation.size() ? fit.correlation(a, b) : NAN;
      if (std::isfinite(c) && std::abs(c) >= 0.5)
        list += "  " + std::string(kUnitParameterNames[static_cast<std::size_t>(a)]) + " / " +
                std::string(kUnitParameterNames[static_cast<std::size_t>(b)]) + ": " +
                format("%+.2f", c) + "\n";
    }
  out += "\nStrong correlations (|r| >= 0.5):\n" + (list.empty() ? "  none\n" : list);
}

}  // namespace

std::string run_unit_static_recording_words(const Recording& rec) {
  const std::string from_run = rec.header_value(kHeaderUnitWanderSource);
  return from_run.empty() ? "" : "its run, by standcald's unit.static_recording: " + from_run;
}

void put_unit_wander_source(json& result, const Recording& rec) {
  if (const std::string from = rec.header_value(kHeaderUnitWanderSource); !from.empty())
    result["unit_wander_source"] = from;
}

ReportContext report_context(const Recording& rec, std::vector<PositionAverage> averages) {
  return {rec.source,          rec.unit_serial,
          rec.program,         rec.g_local_mps2,
          rec.g_from_header,   rec.warnings,
          std::move(averages), run_unit_static_recording_words(rec)};
}

json noise_finding_json(const NoiseFinding& n) {
  const auto vec = [](const Vec3& v) { return json::array({v[0], v[1], v[2]}); };
  json j = {{"model", n.model},
            {"bias_instability", n.bias_instability},
            {"lr", n.lr},
            {"lr_threshold", n.lr_threshold},
            {"how", n.how}};
  if (n.model == "gauss_markov") {
    j["source"] = n.source;
    j["wander_ug"] = vec(n.wander_ug);
    if (!specified_axes_words(n).empty())
      j["wander_axes_specified"] = json::array(
          {n.wander_axes_specified[0], n.wander_axes_specified[1], n.wander_axes_specified[2]});
    j["tau_s"] = n.tau_s;
    j["tau_given"] = n.tau_given;
    if (n.tau_given_max_s > 0)
      j["tau_given_s"] = json::array({n.tau_given_min_s, n.tau_given_max_s});
    if (n.tau_given_open_above) j["tau_given_open_above"] = true;
    if (n.unit_wander_given)
      j["unit_wander_from"] = n.unit_wander_from.empty() ? "given" : n.unit_wander_from;
    if (n.tau_plausible_max_s > 0)
      j["tau_plausible_s"] = json::array({n.tau_plausible_min_s, n.tau_plausible_max_s});
    j["allan_floor_ug"] = vec(n.allan_peak_ug);
  }
  if (n.sigmas_allow_wander_up_to_ug > 0) {
    j["sigmas_allow_wander_up_to_ug"] = n.sigmas_allow_wander_up_to_ug;
    j["sigmas_allowance_weighs_allan_curves"] = n.sigmas_allowance_weighs_allan_curves;
    if (n.sigmas_allowance_weighs_allan_curves)
      j["sigmas_allowance_allan_curves_from"] = n.sigmas_allowance_allan_curves_from;
  }
  if (n.model == "gauss_markov" || (n.allan && n.allan->sample_correlation))
    j["sigma_sqrt_n_understated_by"] = vec(n.understated_in_total());
  if (n.allan) {
    const auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
    json axes = json::object();
    for (int a = 0; a < 3; ++a) {
      const NoiseFigures& f = n.allan->figures[static_cast<std::size_t>(a)];
      axes[std::string(1, "xyz"[a])] = {{"white_density_ug_rthz", opt(f.white_density)},
                                        {"bias_instability_ug", opt(f.bias_instability)},
                                        {"bias_instability_tau_s", f.bias_instability_tau_s},
                                        {"random_walk_ug_rts", opt(f.random_walk)}};
    }
    j["allan"] = {{"source", "the dwells' raw samples, pooled"},
                  {"segments", n.allan->segments},
                  {"sample_period_s", n.allan->sample_period_s},
                  {"axes", axes}};
    if (const auto& c = n.allan->sample_correlation)
      j["allan"]["sample_correlation"] = {{"tau_s", c->tau_s},
                                          {"tau_max_s", c->tau_max_s},
                                          {"dwell_error_over_sigma_sqrt_n", vec(c->factor)}};
  }
  return j;
}

json fit_to_json(const FitResult& fit) {
  json params = json::object();
  for (int j = 0; j < kUnitParameterCount; ++j) {
    const ParameterEstimate& p = fit.unit[static_cast<std::size_t>(j)];
    json e{{"unit", std::string(kUnitParameterUnits[static_cast<std::size_t>(j)])}};
    e["value"] = p.value ? json(*p.value * report_scale(j)) : json(nullptr);
    e["sigma"] = p.sigma ? json(*p.sigma * report_scale(j)) : json(nullptr);
    if (p.value && std::isfinite(p.dof)) e["dof"] = p.dof;
    if (!p.value) e["unobservable_reason"] = p.unobservable_reason;
    params[std::string(kUnitParameterNames[static_cast<std::size_t>(j)])] = e;
  }
  json correlation = json::array();
  for (Eigen::Index a = 0; a < fit.correlation.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < fit.correlation.cols(); ++b)
      row.push_back(number_or_null(fit.correlation(a, b)));
    correlation.push_back(row);
  }
  json residuals = json::array();
  for (const PositionResidual& r : fit.residuals) {
    json res = json::array(), sig = json::array();
    for (Eigen::Index c = 0; c < r.residual_g.size(); ++c) {
      res.push_back(r.residual_g[c] / kUg);
      sig.push_back(r.sigma_g[c] / kUg);
    }
    residuals.push_back({{"pos", r.pos},
                         {"alpha1_cmd_deg", r.alpha1_cmd_deg},
                         {"alpha2_cmd_deg", r.alpha2_cmd_deg},
                         {"mount", mount_name(r.mount)},
                         {"residual_ug", res},
                         {"sigma_ug", sig}});
  }
  json out{{"estimator", fit.estimator},
           {"positions", fit.positions},
           {"parameters_estimated", fit.parameters_estimated},
           {"redundancy", fit.redundancy},
           {"residual_rms_ug", fit.residual_rms_g / kUg},
           {"chi2", fit.chi2},
           {"chi2_dof", number_or_null(fit.chi2_dof)},
           {"parameters", params},
           {"correlation_order",
            json(std::vector<std::string>(kUnitParameterNames.begin(), kUnitParameterNames.end()))},
           {"correlation", correlation},
           {"residuals", residuals},
           {"noise", noise_finding_json(fit.noise)},
           {"notes", fit.notes}};
  if (!fit.stand.empty()) {
    json stand = json::object();
    for (const StandEstimate& s : fit.stand)
      stand[s.name] = {
          {"value", s.value}, {"sigma", s.sigma}, {"unit", s.unit}, {"description", s.description}};
    out["stand"] = stand;
  }
  return out;
}

namespace {

// How the correlation time was come by: given, or the range one run allows, on which the
// biases' sigmas depend several-fold (docs/calibration.md, "Noise model").
std::string tau_words(const NoiseFinding& n, bool static_recording_given) {
  const char* given_as = n.unit_wander_from == kWanderFromRecording ? " (the long dwell allows "
                         : n.unit_wander_from == kWanderFromStaticRecording
                             ? " (the unit's static recording allows "
                             : " (given as ";
  if (n.tau_given_open_above)
    return " (a long static stretch's Allan curves see a wander they do not pin, and put its "
           "correlation time at " +
           format("%.0f", n.tau_given_max_s > 0 ? n.tau_given_min_s : n.tau_s) +
           " s or longer; the biases' sigmas allow for " +
           (n.tau_given_max_s > 0
                ? "up to " + format("%.0f", n.tau_given_max_s) +
                      " s, the longest the fits model, at the widest of those times"
                : std::string("that time, at or beyond the longest the fits model")) +
           ": a static recording of about 100 times it pins it, or give the unit's)";
  if (n.tau_given && n.tau_given_max_s > 0)
    return std::string(given_as) + format("%.0f", n.tau_given_min_s) + "-" +
           format("%.0f", n.tau_given_max_s) + " s; the biases' sigmas allow for it)";
  if (n.tau_given) return " (given)";
  if (n.tau_plausible_max_s <= n.tau_plausible_min_s) return "";
  // Beside a static recording the command refuses --bias-instability-*.
  return " (this run allows " + format("%.0f", n.tau_plausible_min_s) + "-" +
         format("%.0f", n.tau_plausible_max_s) +
         " s, and the biases' sigmas lean on it: give the unit's correlation time, " +
         (static_recording_given
              ? "as a static recording of the unit whose Allan curves pin it, or in its place "
                "--bias-instability-tau-s)"
              : "--bias-instability-tau-s or standcald's unit.bias_instability_tau_s)");
}

// The samples' own correlation within a dwell, where the Allan curves show one.
std::string sample_correlation_words(const NoiseFinding& n) {
  if (!n.allan || !n.allan->sample_correlation) return "";
  const SampleCorrelation& c = *n.allan->sample_correlation;
  return "; the samples are correlated over about " + format("%.3g", c.tau_s) +
         " s (the unit's output filter), so each dwell mean's standard error is sigma/sqrt(n) x " +
         axes_text("%.2f", c.factor[0], c.factor[1], c.factor[2]);
}

}  // namespace

// One line on the noise the fit weighted with, in the engineer's words.
std::string noise_line(const NoiseFinding& n, bool static_recording_given) {
  if (n.model != "gauss_markov") {
    if (n.lr_threshold <= 0) return "white (" + n.how + ")" + sample_correlation_words(n);
    return "white: no bias wander between dwells (2 delta log L = " + format("%.1f", n.lr) + ", " +
           format("%.1f", n.lr_threshold) +
           " needed); each dwell mean weighted by its own standard error" +
           sigmas_allowance_words(n, "dwells") + sample_correlation_words(n);
  }
  const std::string unit =
      n.unit_wander_from == kWanderFromRecording
          ? "the unit's bias wander as this recording's long dwell shows it (its Allan curves)"
      : n.unit_wander_from == kWanderFromStaticRecording
          ? "the unit's bias wander as its static recording shows it (its Allan curves)"
      : n.unit_wander_from == kWanderFromHeader
          ? "the specified bias wander its run was made with (the recording's header)"
          : "the specified bias wander";
  const std::string what =
      n.source != "estimated"
          ? (n.bias_instability ? unit + " (this run shows one that agrees)" : unit)
      : n.bias_instability
          ? "bias wander estimated from this run"
          : "a possible bias wander (below the bar of a finding: 2 delta log L = " +
                format("%.1f", n.lr) + " of " + format("%.1f", n.lr_threshold) + "), weighted for";
  return what + ", Gauss-Markov " +
         axes_text("%.2f", n.wander_ug[0], n.wander_ug[1], n.wander_ug[2], "ug") +
         specified_axes_words(n) + ", tau " + format("%.0f", n.tau_s) + " s" +
         tau_words(n, static_recording_given) +
         "; dwell means close in time share it, so they are weighted by the covariance it "
         "implies "
         "(generalised least squares); sigma/sqrt(n) understates a dwell mean's error up to " +
         format("%.1f", n.understated_in_total().maxCoeff()) + "x" +
         sigmas_allowance_words(n, "dwells") + sample_correlation_words(n);
}

std::string format_report(const FitResult& fit, const ReportContext& ctx) {
  std::string out = "standcal calibration report\n===========================\n";
  out += "Recording:  " + ctx.source + "\n";
  out += "Unit:       " + (ctx.unit_serial.empty() ? std::string("(no serial)") : ctx.unit_serial) +
         "\n";
  out += "Programme:  " + (ctx.program.empty() ? std::string("(not stated)") : ctx.program) + ", " +
         std::to_string(fit.positions) + " positions\n";
  out += "Gravity:    " + format("%.5f", ctx.g_local_mps2) + " m/s^2" +
         (ctx.g_from_header ? " (from the recording)" : " (ASSUMED standard gravity)") + "\n";
  out += "Estimator:  " + fit.estimator + ", " + std::to_string(fit.parameters_estimated) +
         " parameters, redundancy " + std::to_string(fit.redundancy) + "\n";
  const std::string& unit_static = ctx.unit_static_recording;
  out += "Noise:      " + noise_line(fit.noise, !unit_static.empty()) + "\n";
  if (const std::string advice = unit_wander_advice(fit.noise, !unit_static.empty());
      !advice.empty())
    out += "            " + advice + "\n";
  if (!unit_static.empty()) out += "            " + unit_static + "\n";
  for (const std::string& w : ctx.warnings) out += "WARNING:    " + w + "\n";
  out += "\nUnit parameters (value +- 1 sigma):\n";
  append_parameters(out, fit);
  if (!fit.stand.empty()) {
    out += "\nStand health (identifiable stand-error combinations):\n";
    for (const StandEstimate& s : fit.stand) {
      char line[120];
      std::snprintf(line, sizeof line, "  %+10.2f +- %6.2f %-7s ", s.value, s.sigma,
                    s.unit.c_str());
      out += line + s.name + "\n      " + s.description + "\n";
    }
  }
  out += "\nModel check: residual rms " + format("%.3f", fit.residual_rms_g / kUg) +
         " ug; chi2/dof " + chi2_verdict(fit) + "\n";
  append_strong_correlations(out, fit);
  append_residuals(out, fit, ctx);
  if (!fit.notes.empty()) {
    out += "\nNotes:\n";
    for (const std::string& n : fit.notes) out += "  - " + n + "\n";
  }
  return out;
}

}  // namespace standcal
