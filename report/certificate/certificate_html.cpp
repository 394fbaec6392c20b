// render_certificate_html(): the page. Elements a program may read carry ids and data-
// attributes (tests/certificate parses them): #verdict, #traceability dd[data-field],
// #parameters tr[data-parameter] td.value/.U/.limit/.margin/.outcome, #rule, #compensation,
// figure#residuals-invariant, figure#residuals-axes, #diagnosis.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string>

#include "calib/distributions.hpp"
#include "calib/parameters.hpp"
#include "calib/report.hpp"
#include "calib/text.hpp"
#include "report/certificate/certificate.hpp"
#include "report/history/html_page.hpp"
#include "report/plot/figure.hpp"

namespace standcal::report {

namespace {

using records::Outcome;

// A4 pages with the certificate number in every page's footer (WeasyPrint and browsers
// that print with CSS paged media), tables and figures not split across pages.
const std::string kPrintStyle =
    "<style>\n@page{size:A4;margin:18mm 16mm 20mm 16mm;"
    "@bottom-left{content:string(certno);font-size:8pt}"
    "@bottom-right{content:\"page \" counter(page) \" of \" counter(pages);font-size:8pt}}\n"
    "#certificate-number{string-set:certno content()}\n"
    "@media "
    "print{body{max-width:none;margin:0;font-size:9.5pt}table,figure,dl{page-break-inside:avoid}"
    "h2{page-break-after:avoid}#budget{font-size:8pt}}\n"
    "header#lab{border-bottom:1px solid #333;margin-bottom:.5em}header#lab p{margin:.1em 0}\n"
    "td.signature-line{min-width:10em;height:2.2em}\n</style>\n";

std::string plain_name(int p) {
  static const char* names[kUnitParameterCount] = {
      "Bias (zero offset), x axis",       "Bias (zero offset), y axis",
      "Bias (zero offset), z axis",       "Scale-factor error, x axis",
      "Scale-factor error, y axis",       "Scale-factor error, z axis",
      "Non-orthogonality, x–y axis pair", "Non-orthogonality, x–z axis pair",
      "Non-orthogonality, y–z axis pair"};
  return names[p];
}

std::string outcome_label(Outcome o) {
  switch (o) {
    case Outcome::pass:
      return "PASS";
    case Outcome::fail:
      return "FAIL";
    case Outcome::indeterminate:
      return "INDETERMINATE";
    case Outcome::not_evaluated:
      return "NOT MEASURED";
    case Outcome::no_limit:
      return "no limit";
  }
  return "";
}

std::string or_unknown(const std::string& s) { return s.empty() ? "(not recorded)" : s; }

std::string field(const std::string& id, const std::string& label, const std::string& value) {
  return "<dt>" + html_escape(label) + "</dt><dd data-field=\"" + id + "\">" + html_escape(value) +
         "</dd>\n";
}

std::string how_to_read(const CertificateInput& in) {
  const std::string k = compact(in.coverage_factor);
  const std::string u_is =
      in.budget ? "U combines the fit's own uncertainty with the stand's, gravity's and "
                  "temperature's, as the uncertainty budget shows"
                : "U is " + k + " standard uncertainties of the fit, k = " + k;
  return "<div class=\"howto\"><p><b>How to read this certificate.</b> An accelerometer unit holds "
         "three "
         "accelerometers, one per axis x, y, z. None is perfect: each reads a little when it "
         "should read zero "
         "(<i>bias</i>, in µg, millionths of gravity), its sensitivity is slightly off "
         "(<i>scale-factor error</i>, "
         "in ppm, parts per million), and its axis is not exactly at right angles to the others "
         "(<i>non-orthogonality</i>, in ″, arc-seconds). The unit was turned on a two-axis rotary "
         "stand into "
         "known orientations so that gravity, whose local value is known, was the reference; these "
         "nine errors "
         "were estimated from what it read.</p>"
         "<p>Every result is given as <i>value ± U</i>: the true value lies in that interval with "
         "about 95 % "
         "confidence (" +
         u_is +
         "). Where acceptance limits apply, each "
         "result is marked PASS, FAIL or INDETERMINATE by the rule stated below, and the "
         "<i>margin</i> says how much "
         "room was left once the uncertainty is allowed for. The <i>compensation</i> section gives "
         "the numbers to "
         "load into the navigation system so it corrects these errors. The <i>residual</i> plots "
         "show how far each "
         "measurement was from the fitted model: points scattered around zero within their bars "
         "mean the model "
         "describes the unit well.</p></div>\n";
}

std::string verdict_section(const CertificateInput& in) {
  if (!in.conformity)
    return "<p id=\"verdict\" class=\"verdict\" data-outcome=\"no_limit\">No acceptance limits "
           "were applied: the "
           "values below are measured results without a pass/fail statement.</p>\n";
  const records::ConformityReport& c = *in.conformity;
  const std::string o = records::outcome_name(c.overall);
  return "<p id=\"verdict\" class=\"verdict " + o + "\" data-outcome=\"" + o +
         "\">Result: " + outcome_label(c.overall) + "</p>\n<p>" + html_escape(c.overall_text) +
         " Limits for unit type <b>" + html_escape(c.unit_type) + "</b> from <code>" +
         html_escape(c.limits_source) + "</code>.</p>\n";
}

std::string traceability_section(const CertificateInput& in) {
  const CertificateTraceability& t = in.trace;
  std::string out = "<h2>What was calibrated, where and by whom</h2>\n<dl id=\"traceability\">\n";
  out += field("unit_serial", "Unit serial number", or_unknown(t.unit_serial));
  out += field("unit_type", "Unit type", or_unknown(t.unit_type));
  out += field("stand_id", "Calibration stand", or_unknown(t.stand_id));
  out += field("date", "Date of calibration (UTC)",
               or_unknown(t.started_utc) + (t.ended_utc.empty() ? "" : " to " + t.ended_utc));
  out += field("operator", "Operator", or_unknown(t.operator_name));
  out += field("software_version", "Software version (recording)", or_unknown(t.software_version));
  out += field("config_hash", "Configuration hash", or_unknown(t.config_hash));
  out += field("g_local", "Local gravity g used as reference", fixed(t.g_local_mps2, 5) + " m/s²");
  out += field("g_source", "Source of g", or_unknown(t.g_source));
  out += field("run_id", "Run", or_unknown(t.run_id));
  out += field("recording", "Recording (raw data)", or_unknown(t.recording_path));
  out += field("origin", "Taken from", t.origin);
  out += field("issued", "Certificate issued (UTC)",
               in.issued_utc + " by standcal " + in.issuing_software_version);
  return out + "</dl>\n";
}

std::string programme_section(const CertificateInput& in) {
  std::string out =
      "<h2>How it was measured</h2>\n<p>Programme <b>" + html_escape(or_unknown(in.program_name)) +
      "</b>: the stand turned the unit into the " + std::to_string(in.positions.size()) +
      " orientations below and recorded its outputs at rest in each. The parameters were estimated "
      "with the <b>" +
      html_escape(in.fit.estimator) + "</b> method from " + std::to_string(in.fit.positions) +
      " positions; redundancy (positions beyond the minimum) " + std::to_string(in.fit.redundancy) +
      ".</p>\n";
  out +=
      "<table id=\"positions\">\n<tr><th>position</th><th>outer axis α1 (°)</th><th>inner axis α2 "
      "(°)</th>"
      "<th>mounting</th><th>samples</th><th>dwell (s)</th><th>temperature (°C)</th></tr>\n";
  for (const PositionAverage& p : in.positions) {
    out += "<tr><td class=\"num\">" + std::to_string(p.pos + 1) + "</td><td class=\"num\">" +
           fixed(p.alpha1_cmd_deg, 2) + "</td><td class=\"num\">" + fixed(p.alpha2_cmd_deg, 2) +
           "</td><td>" + html_escape(mount_name(p.mount)) + "</td><td class=\"num\">" +
           std::to_string(p.samples) + "</td><td class=\"num\">" +
           fixed(p.t_end_s - p.t_start_s, 1) + "</td><td class=\"num\">" +
           (std::isfinite(p.temp_mean_c) ? fixed(p.temp_mean_c, 2) : std::string("—")) +
           "</td></tr>\n";
  }
  return out + "</table>\n";
}

const records::ParameterConformity* conformity_of(const CertificateInput& in, int p) {
  if (!in.conformity) return nullptr;
  for (const records::ParameterConformity& c : in.conformity->parameters)
    if (c.parameter == p) return &c;
  return nullptr;
}

// The guarded margin L - (|value| + U) with the digits that show its sign (a fail by 0.004
// read "-0.00"); none within the limit rule's tolerance.
std::string margin_text(const records::ParameterConformity& c) {
  const double margin = c.value_decision.guarded_margin;
  if (records::negligible_against_limit(margin, *c.limit.max_abs)) return "0.00";
  return fixed(margin, fixed_decimals_apart(margin, 0, 2), true);
}

std::string parameter_row(const CertificateInput& in, int p) {
  const ParameterEstimate& e = in.fit.unit[static_cast<std::size_t>(p)];
  const std::string name(kUnitParameterNames[static_cast<std::size_t>(p)]);
  const std::string unit = unit_symbol(kUnitParameterUnits[static_cast<std::size_t>(p)]);
  const records::ParameterConformity* c = conformity_of(in, p);
  const Outcome outcome = c ? c->outcome : Outcome::no_limit;
  const std::string o = records::outcome_name(outcome);
  std::string row = "<tr data-parameter=\"" + name + "\" data-outcome=\"" + o + "\"><td>" +
                    html_escape(plain_name(p)) + "<br><code>" + name + "</code></td>";
  if (e.value && e.sigma) {
    const double value = *e.value * report_scale(p);
    const double U =
        in.budget ? in.budget->parameters[static_cast<std::size_t>(p)].expanded * report_scale(p)
                  : in.coverage_factor * std::abs(*e.sigma * report_scale(p));
    row += "<td class=\"num value\">" + fixed(value, 2, true) + "</td><td class=\"num U\">± " +
           fixed(U, 2) + "</td><td>" + unit + "</td>";
  } else {
    row += "<td class=\"value\" colspan=\"2\">not measured</td><td>" + unit + "</td>";
  }
  std::string limit = "—", margin = "—";
  // The limits as the lab wrote them (one decimal said 5.005 as 5.0).
  if (c && c->limit.max_abs) limit = "|value| ≤ " + round_trip_text(*c->limit.max_abs);
  if (c && c->limit.max_sigma)
    limit +=
        (limit == "—" ? "" : "<br>") + std::string("σ ≤ ") + round_trip_text(*c->limit.max_sigma);
  if (c && c->value && c->limit.max_abs) margin = margin_text(*c);
  row += "<td class=\"num limit\">" + limit + "</td><td class=\"num margin\">" + margin +
         "</td><td class=\"outcome " + o + "\">" + outcome_label(outcome) +
         "</td><td class=\"explanation\">" +
         html_escape(c         ? c->explanation
                     : e.value ? std::string()
                               : "not measured: " + e.unobservable_reason) +
         "</td></tr>\n";
  return row;
}

std::string chi2_sentence(const FitResult& fit) {
  if (fit.redundancy <= 0 || !std::isfinite(fit.chi2_dof))
    return "Not testable: the programme has no redundant positions, so the fit passes through "
           "every measurement "
           "and cannot reveal a wrong model.";
  const double p = chi_square_upper_tail(fit.chi2, fit.redundancy);
  std::string s = "χ²/dof = " + fixed(fit.chi2_dof, 2) + " with " + std::to_string(fit.redundancy) +
                  " degrees of freedom (p = " + fixed(p, 3) + "): ";
  if (p < 1e-3)
    return s +
           "the residuals are larger than the measured noise explains; the model misses something.";
  if (p > 0.999)
    return s +
           "the residuals are smaller than the noise predicts; uncertainties may be overstated.";
  return s + "consistent with the measured noise.";
}

std::string results_section(const CertificateInput& in) {
  const std::string u_header =
      in.budget ? "U (95 %, the budget below)" : "U (k = " + compact(in.coverage_factor) + ")";
  std::string out =
      "<h2>Results: the unit's instrument errors</h2>\n<table id=\"parameters\">\n"
      "<tr><th>parameter</th><th>value</th><th>" +
      u_header +
      "</th><th>unit</th><th>limit</th><th>margin<br>(limit − |value| − U)</th><th>result</th>"
      "<th>why</th></tr>\n";
  for (int p = 0; p < kUnitParameterCount; ++p) out += parameter_row(in, p);
  out += "</table>\n";
  out += "<p id=\"model-check\"><b>Model check.</b> Residual rms " +
         fixed(in.fit.residual_rms_g / kUg, 3) + " µg. " + html_escape(chi2_sentence(in.fit));
  if (in.conformity && in.conformity->model_check.outcome != Outcome::no_limit)
    out += " Limit: " + html_escape(in.conformity->model_check.explanation) + " (" +
           (in.conformity->model_check.outcome == Outcome::not_evaluated
                ? std::string("NOT EVALUATED")
                : outcome_label(in.conformity->model_check.outcome)) +
           ").";
  // What every sigma and U on the page rests on: the unit's wander given, found or none.
  // The unit's static recording given to this certificate, else what standcald's gave the run.
  std::string static_words = in.unit_static_recording
                                 ? unit_static_recording_words(*in.unit_static_recording)
                                 : in.run_unit_static_recording;
  out += "</p>\n<p id=\"noise-model\"><b>Noise model.</b> The uncertainties rest on: " +
         html_escape(noise_line(in.fit.noise, !static_words.empty())) + ".";
  if (!static_words.empty()) {
    // "the unit's static recording …" / "its run, by …" opens a sentence here
    static_words[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(static_words[0])));
    out += " " + html_escape(static_words) + ".";
  }
  out += "</p>\n<h2>Decision rule</h2>\n<p id=\"rule\">" +
         html_escape(records::decision_rule_text(in.coverage_factor, in.budget.has_value())) +
         (in.budget ? std::string(" The budget is below; k differs from parameter to parameter.")
                    : std::string(
                          " No uncertainty budget was given (--budget): σ is the fit's statistical "
                          "uncertainty only, and the stand, gravity, temperature and method are "
                          "not in U.")) +
         "</p>\n";
  return out;
}

std::string budget_cell(double v) { return "<td class=\"num\">" + fixed(v, 3) + "</td>"; }

std::string budget_inputs_table(const UncertaintyBudget& b) {
  std::string out =
      "<table id=\"budget-inputs\">\n<tr><th>input quantity</th><th>distribution</th>"
      "<th>bound or u</th><th>source</th></tr>\n";
  for (const BudgetInput& in : b.inputs) {
    const bool normal = in.distribution == Distribution::normal;
    out += "<tr><td>" + html_escape(in.name) + "</td><td>" + (normal ? "normal" : "rectangular") +
           "</td><td class=\"num\">" + (normal ? "u = " : "± ") + compact(in.stated) + " " +
           html_escape(in.stated_unit) + "</td><td>" + html_escape(in.source) + "</td></tr>\n";
  }
  return out + "</table>\n";
}

// Parameters as columns, contributions as rows, in the parameters' report units.
std::string budget_table(const UncertaintyBudget& b) {
  std::vector<int> shown;
  for (const ParameterBudget& p : b.parameters)
    if (p.observable) shown.push_back(p.parameter);
  std::string out = "<table id=\"budget\">\n<tr><th>contribution u<sub>i</sub></th>";
  for (int p : shown)
    out += "<th>" + std::string(kUnitParameterNames[static_cast<std::size_t>(p)]) + "<br>" +
           unit_symbol(kUnitParameterUnits[static_cast<std::size_t>(p)]) + "</th>";
  out += "</tr>\n<tr data-row=\"type-a\"><td>type A: the fit (noise model)</td>";
  for (int p : shown)
    out += budget_cell(b.parameters[static_cast<std::size_t>(p)].type_a * report_scale(p));
  out += "</tr>\n";
  for (std::size_t k = 0; k < b.inputs.size(); ++k) {
    out += "<tr data-row=\"type-b\"><td>type B: " + html_escape(b.inputs[k].name) + "</td>";
    for (int p : shown)
      out +=
          budget_cell(b.parameters[static_cast<std::size_t>(p)].contribution[k] * report_scale(p));
    out += "</tr>\n";
  }
  const auto row = [&](const char* id, const std::string& label, auto cell) {
    out += std::string("<tr data-row=\"") + id + "\"><th>" + label + "</th>";
    for (int p : shown) out += cell(b.parameters[static_cast<std::size_t>(p)], p);
    out += "</tr>\n";
  };
  row("combined", "combined standard uncertainty u<sub>c</sub>",
      [](const ParameterBudget& x, int p) { return budget_cell(x.combined * report_scale(p)); });
  row("dof", "effective degrees of freedom ν<sub>eff</sub>", [](const ParameterBudget& x, int) {
    return "<td class=\"num\">" +
           (std::isfinite(x.dof_effective) ? fixed(x.dof_effective, 0) : std::string("∞")) +
           "</td>";
  });
  row("k", "coverage factor k (95 %)",
      [](const ParameterBudget& x, int) { return budget_cell(x.coverage_factor); });
  row("expanded", "expanded uncertainty U = k·u<sub>c</sub>",
      [](const ParameterBudget& x, int p) { return budget_cell(x.expanded * report_scale(p)); });
  return out + "</table>\n";
}

std::string budget_section(const CertificateInput& in) {
  if (!in.budget) return "";
  const UncertaintyBudget& b = *in.budget;
  std::string out =
      "<h2>Uncertainty budget (GUM, JCGM 100:2008)</h2>\n<p>Type A is the fit's standard "
      "uncertainty with the noise model stated above. Each type B input is propagated through the "
      "certified estimator "
      "itself: the estimator is run on the measurements as the input at ±u would have changed them "
      "(the stand "
      "through the exact rotation model, gravity as a scale of every mean, a temperature "
      "coefficient through the "
      "dwells' temperatures), which gives its sensitivity coefficient and, where the method is "
      "blind to it at first "
      "order, its second-order effect; both are in u<sub>i</sub>. The effective degrees of freedom "
      "are "
      "Welch–Satterthwaite's, with the stated bounds taken as exact.</p>\n";
  out += budget_inputs_table(b) + budget_table(b);
  if (!b.not_budgeted.empty()) {
    out += "<p><b>Not budgeted</b> (no bound given):</p>\n<ul id=\"not-budgeted\">\n";
    for (const std::string& m : b.not_budgeted) out += "<li>" + html_escape(m) + "</li>\n";
    out += "</ul>\n";
  }
  return out;
}

std::string compensation_section(const CertificateInput& in) {
  const Compensation& c = in.compensation;
  std::string out =
      "<h2>Compensation to load into the navigation system</h2>\n<p>The navigation computer turns "
      "the "
      "unit's raw outputs f<sub>raw</sub> (m/s², converted with the nominal scale factors) into "
      "corrected specific force with <b>f = M · (f<sub>raw</sub> − b)</b>:</p>\n"
      "<table id=\"compensation\">\n<tr><th></th><th>x</th><th>y</th><th>z</th></tr>\n<tr><th>b "
      "(m/s²)</th>";
  for (int i = 0; i < 3; ++i) out += "<td class=\"num\">" + fixed(c.bias[i], 9, true) + "</td>";
  out += "</tr>\n";
  for (int r = 0; r < 3; ++r) {
    out += "<tr><th>M row " + std::to_string(r + 1) + "</th>";
    for (int k = 0; k < 3; ++k)
      out += "<td class=\"num\">" + fixed(c.matrix(r, k), 12, true) + "</td>";
    out += "</tr>\n";
  }
  out += "</table>\n<p>g = " + fixed(c.g_local_mps2, 5) +
         " m/s². Checksum (CRC-32 of the numbers) <code id=\""
         "compensation-checksum\">" +
         compensation_checksum(c) +
         "</code>. Machine-readable, with the covariance: "
         "<code>standcal run result RUN --compensation FILE</code> (standcald keeps it as "
         "<code>runs/RUN/compensation.json</code>) or <code>standcal fit RECORDING --compensation "
         "FILE</code>.</p>\n<ul>\n";
  for (const std::string& n : c.notes) out += "<li>" + html_escape(n) + "</li>\n";
  return out + "</ul>\n";
}

plot::Panel residual_panel(const std::string& title, const FitResult& fit, Eigen::Index component) {
  plot::Series s;
  s.label = "residual ± 1σ";
  for (const PositionResidual& r : fit.residuals) {
    if (component >= r.residual_g.size()) continue;
    s.x.push_back(r.pos + 1);
    s.y.push_back(r.residual_g[component] / kUg);
    s.y_sigma.push_back(r.sigma_g[component] / kUg);
  }
  plot::Panel panel;
  panel.title = title;
  panel.x_label = "position";
  panel.y_label = "residual (ug)";
  panel.y_reference = 0.0;
  panel.series.push_back(std::move(s));
  return panel;
}

std::string figure_html(const std::string& id, const plot::Figure& f, const std::string& caption) {
  return "<figure id=\"" + id + "\">\n" + plot::render_svg_inline(f, id) + "\n<figcaption>" +
         html_escape(caption) + "</figcaption>\n</figure>\n";
}

std::string residuals_section(const CertificateInput& in) {
  std::string out =
      "<h2>Residuals: how well the model fits each position</h2>\n<p>A residual is what the unit "
      "read minus what the fitted model predicts, in µg. Bars are ±1 standard error of the dwell "
      "average. Residuals scattered around zero, mostly within their bars, mean the model explains "
      "the measurements; a pattern (a trend, one position far out) means something the model "
      "leaves "
      "out, which the diagnosis section looks for.</p>\n";
  if (in.invariant && !in.invariant->residuals.empty()) {
    plot::Figure f;
    f.panel_height_px = 260;
    f.panels.push_back(residual_panel(
        "Along gravity (the invariant measurement u.J - 1), per position", *in.invariant, 0));
    out += figure_html(
        "residuals-invariant", f,
        "Residual of the measurement along gravity, per position (the quantity the nine parameters "
        "are estimated from). With no redundant positions they are zero by construction.");
  }
  if (in.full && !in.full->residuals.empty() && in.full->residuals.front().residual_g.size() == 3) {
    plot::Figure f;
    f.panel_height_px = 220;
    const char* axes[3] = {"x", "y", "z"};
    for (Eigen::Index a = 0; a < 3; ++a)
      f.panels.push_back(residual_panel(
          std::string(axes[a]) + " accelerometer, per position (full-vector fit)", *in.full, a));
    out += figure_html("residuals-axes", f,
                       "Residual of each accelerometer axis per position, from the full-vector "
                       "fit, which also uses "
                       "the components across gravity and estimates the stand's own errors.");
  }
  return out;
}

std::string diagnosis_section(const CertificateInput& in) {
  std::string out = "<h2>Diagnosis of model mismatch</h2>\n";
  if (!in.diagnosis)
    return out +
           "<p id=\"diagnosis\" data-verdict=\"not_run\">No diagnosis was run for this calibration "
           "(<code>standcal certificate --diagnose</code> runs one).</p>\n";
  const CertificateDiagnosis& d = *in.diagnosis;
  out += "<div id=\"diagnosis\" data-verdict=\"" + html_escape(d.verdict) +
         "\"><p>The diagnosis tests whether the "
         "residuals are only noise and, if not, which physics missing from the model explains "
         "them. Verdict: <b>" +
         html_escape(d.verdict) + "</b> (from " + html_escape(d.origin) + ").</p>\n<ul>\n";
  for (const std::string& s : d.summary) out += "<li>" + html_escape(s) + "</li>\n";
  for (const std::string& s : d.located) out += "<li>" + html_escape(s) + "</li>\n";
  return out + "</ul></div>\n";
}

std::string notes_section(const CertificateInput& in) {
  if (in.warnings.empty() && in.fit.notes.empty()) return {};
  std::string out = "<h2>Remarks</h2>\n<ul id=\"remarks\">\n";
  for (const std::string& w : in.warnings) out += "<li>" + html_escape(w) + "</li>\n";
  for (const std::string& n : in.fit.notes) out += "<li>" + html_escape(n) + "</li>\n";
  return out + "</ul>\n";
}

}  // namespace

// The issuer and the certificate's identity, first on the page (#lab, #certificate-number).
std::string header_section(const CertificateInput& in) {
  std::string out = "<header id=\"lab\">\n";
  if (in.lab) {
    out += "<p class=\"lab-name\"><b>" + html_escape(in.lab->name) + "</b></p>\n";
    if (!in.lab->address.empty())
      out += "<p class=\"lab-address\">" + html_escape(in.lab->address) + "</p>\n";
    if (!in.lab->accreditation.empty())
      out += "<p class=\"lab-accreditation\">" + html_escape(in.lab->accreditation) + "</p>\n";
  } else {
    out +=
        "<p class=\"lab-name\">Issuing laboratory not configured (<code>--lab FILE</code>): this "
        "page is a "
        "calibration record, not a certificate a laboratory has issued.</p>\n";
  }
  out += "<p>Certificate number <b id=\"certificate-number\">" +
         html_escape(in.certificate_number) + "</b>, issued <span id=\"issue-date\">" +
         html_escape(in.issued_utc) + "</span></p>\n";
  return out + "</header>\n";
}

// Names and roles from the laboratory file; "not signed" until a person signs the print.
std::string signature_section(const CertificateInput& in) {
  std::string out =
      "<h2>Signatures</h2>\n<table id=\"signatures\">\n<tr><th>name</th><th>role</th><th>signature"
      "</th><th>date</th><th>status</th></tr>\n";
  if (!in.lab || in.lab->signatories.empty()) {
    out +=
        "<tr data-status=\"not-signed\"><td colspan=\"4\">no signatories configured "
        "(<code>signatories</code> in the "
        "laboratory file)</td><td>not signed</td></tr>\n";
  } else {
    for (const Signatory& s : in.lab->signatories)
      out += "<tr data-status=\"not-signed\"><td>" + html_escape(s.name) + "</td><td>" +
             html_escape(s.role) +
             "</td><td class=\"signature-line\"></td><td class=\"signature-line\"></td><td>not "
             "signed</td></tr>\n";
  }
  return out +
         "</table>\n<p>This certificate shall not be reproduced except in full. The results relate "
         "only to the "
         "unit calibrated.</p>\n";
}

std::string render_certificate_html(const CertificateInput& in) {
  const std::string serial = in.trace.unit_serial.empty() ? "(no serial)" : in.trace.unit_serial;
  std::string out =
      html_page_start("Calibration certificate " + in.certificate_number, kPrintStyle);
  out += header_section(in);
  out += "<h1>Calibration certificate: accelerometer unit " + html_escape(serial) + "</h1>\n";
  out += how_to_read(in);
  out += verdict_section(in);
  out += traceability_section(in);
  out += programme_section(in);
  out += results_section(in);
  out += budget_section(in);
  out += compensation_section(in);
  out += residuals_section(in);
  out += diagnosis_section(in);
  out += notes_section(in);
  out += signature_section(in);
  return out + html_page_end();
}

}  // namespace standcal::report
