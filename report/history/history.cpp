#include "report/history/history.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <stdexcept>

#include "calib/ageing.hpp"
#include "calib/utc_time.hpp"
#include "report/history/html_page.hpp"
#include "report/plot/figure.hpp"

namespace standcal::report {

namespace {

std::string parameter_name(int p) {
  return std::string(kUnitParameterNames[static_cast<std::size_t>(p)]);
}
std::string parameter_unit(int p) {
  return unit_symbol(kUnitParameterUnits[static_cast<std::size_t>(p)]);
}

std::vector<const HistoryCalibration*> by_date(const UnitHistory& h, std::vector<double>& days) {
  std::vector<std::pair<double, const HistoryCalibration*>> dated;
  for (const HistoryCalibration& c : h.calibrations) dated.emplace_back(utc_days(c.date_utc), &c);
  std::stable_sort(dated.begin(), dated.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<const HistoryCalibration*> out;
  days.clear();
  for (const auto& [d, c] : dated) {
    days.push_back(d);
    out.push_back(c);
  }
  return out;
}

std::string date_only(const std::string& iso) {
  const std::time_t t = static_cast<std::time_t>(std::llround(utc_days(iso) * 86400.0));
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M", &tm);
  return buf;
}

plot::Figure parameter_figure(const UnitHistory& h,
                              const std::vector<const HistoryCalibration*>& cals,
                              const std::vector<double>& days, int p) {
  plot::Series s;
  s.label = "value ± U (k = " + compact(h.coverage_factor) + ")";
  s.style = plot::SeriesStyle::points_and_line;
  for (std::size_t i = 0; i < cals.size(); ++i) {
    const HistoryValue& v = cals[i]->parameters[static_cast<std::size_t>(p)];
    if (!v.value) continue;
    s.x.push_back(days[i] - days.front());
    s.y.push_back(*v.value);
    s.y_sigma.push_back(v.sigma ? h.coverage_factor * *v.sigma : 0.0);
  }
  plot::Panel panel;
  panel.title = parameter_name(p) + " of " + h.unit_serial;
  panel.x_label = "days since the first calibration";
  panel.y_label = parameter_name(p) + " (" +
                  std::string(kUnitParameterUnits[static_cast<std::size_t>(p)]) + ")";
  panel.y_reference = 0.0;
  panel.series.push_back(std::move(s));
  plot::Figure f;
  f.panels.push_back(std::move(panel));
  f.width_px = 900;
  f.panel_height_px = 260;
  return f;
}

std::string calibration_table(const std::vector<const HistoryCalibration*>& cals, double k) {
  std::string out =
      "<table id=\"calibrations\">\n<tr><th>date (UTC)</th><th>run</th><th>verdict</th>";
  for (int p = 0; p < kUnitParameterCount; ++p)
    out += "<th>" + html_escape(parameter_name(p)) + " (" + parameter_unit(p) + ")</th>";
  out += "</tr>\n";
  for (const HistoryCalibration* c : cals) {
    out += "<tr data-run=\"" + html_escape(c->run_id) + "\"><td>" +
           html_escape(date_only(c->date_utc)) + "</td><td>" + html_escape(c->run_id) +
           "</td><td class=\"" + html_escape(c->verdict) + "\">" +
           html_escape(c->verdict.empty() ? "—" : c->verdict) + "</td>";
    for (const HistoryValue& v : c->parameters) {
      if (!v.value) {
        out += "<td>not measured</td>";
        continue;
      }
      out += "<td class=\"num\">" + fixed(*v.value, 1, true) +
             (v.sigma ? " ± " + fixed(k * *v.sigma, 1) : "") + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

std::string drift_section(const std::vector<HistoryDrift>& drifts, double k) {
  std::string out =
      "<h2>Changes between calibrations</h2>\n<p>A change is flagged when it exceeds " +
      compact(k) +
      " times its combined standard uncertainty √(σ₁² + σ₂²): more than measurement noise "
      "explains, "
      "so the unit itself has probably changed (ageing, a shock, a repair) or one calibration is "
      "wrong.</p>\n";
  if (drifts.empty())
    return out + "<p id=\"drifts\" class=\"pass\">No change beyond the uncertainty.</p>\n";
  out += "<ul id=\"drifts\">\n";
  for (const HistoryDrift& d : drifts)
    out += "<li class=\"fail\" data-parameter=\"" + html_escape(parameter_name(d.parameter)) +
           "\">" + html_escape(d.text) + "</li>\n";
  return out + "</ul>\n";
}

}  // namespace

double utc_days(const std::string& iso) {
  // The daemon writes "2026-11-21T22:36:38Z"; run ids carry "20261121T223638Z". A history
  // date says it is UTC.
  const auto seconds = parse_utc_s(iso, UtcParseRules{false, true});
  if (!seconds) {
    throw std::runtime_error("history: '" + iso +
                             "' is not a UTC date like 2026-11-21T22:36:38Z (a day in the "
                             "calendar, with its zone)");
  }
  return static_cast<double>(*seconds) / 86400.0;
}

namespace {

// Every parameter's changes by the one ageing rule, over the calibrations by date.
std::array<std::vector<ParameterChange>, kUnitParameterCount> age(const UnitHistory& h) {
  std::vector<double> days;
  const std::vector<const HistoryCalibration*> cals = by_date(h, days);
  std::array<std::vector<ParameterChange>, kUnitParameterCount> changes;
  for (int p = 0; p < kUnitParameterCount; ++p) {
    std::vector<ParameterObservation> observed;
    for (std::size_t i = 0; i < cals.size(); ++i) {
      const HistoryValue& v = cals[i]->parameters[static_cast<std::size_t>(p)];
      observed.push_back({cals[i]->run_id, days[i], v.value, v.sigma});
    }
    changes[static_cast<std::size_t>(p)] = parameter_changes(observed, h.coverage_factor);
  }
  return changes;
}

}  // namespace

std::vector<HistoryDrift> find_drifts(const UnitHistory& h) {
  const auto changes = h.changes ? *h.changes : age(h);
  std::vector<HistoryDrift> out;
  for (int p = 0; p < kUnitParameterCount; ++p) {
    for (const ParameterChange& c : changes[static_cast<std::size_t>(p)]) {
      if (!c.ageing) continue;
      HistoryDrift d;
      d.parameter = p;
      d.from_run_id = c.from_run_id;
      d.to_run_id = c.to_run_id;
      d.change = c.delta;
      d.change_sigma = c.combined_sigma;
      d.days = c.days;
      d.text = parameter_name(p) + " changed by " + fixed(d.change, 1, true) + " " +
               parameter_unit(p) + " in " + fixed(d.days, 0) + " days (" + d.from_run_id + " → " +
               d.to_run_id + "), " + fixed(std::abs(d.change) / d.change_sigma, 1) +
               " times its combined σ of " + fixed(d.change_sigma, 1) + " " + parameter_unit(p);
      out.push_back(std::move(d));
    }
  }
  return out;
}

std::string render_history_html(const UnitHistory& h) {
  std::vector<double> days;
  const std::vector<const HistoryCalibration*> cals = by_date(h, days);
  const double k = h.coverage_factor;
  std::string out = html_page_start("Calibration history of " + h.unit_serial);
  out += "<h1>Calibration history of unit " + html_escape(h.unit_serial) + "</h1>\n";
  out += "<p>Unit type: " + html_escape(h.unit_type.empty() ? "(not recorded)" : h.unit_type) +
         ". " + std::to_string(cals.size()) + " calibration(s)" +
         (cals.empty() ? std::string(".")
                       : ", from " + date_only(cals.front()->date_utc) + " to " +
                             date_only(cals.back()->date_utc) + " UTC.") +
         "</p>\n";
  out +=
      "<p class=\"howto\"><b>How to read this page.</b> Every calibration of this unit measured "
      "its nine "
      "instrument errors: bias (zero offset, µg), scale-factor error (ppm) and non-orthogonality "
      "of the axis "
      "pairs (″, arc-seconds). The plots show each of them over time; the bars are the expanded "
      "uncertainty "
      "U = " +
      compact(k) +
      "σ. A healthy unit gives points that agree within their bars. A steady trend is ageing; "
      "a jump is a shock, a repair or a faulty calibration.</p>\n";
  if (cals.empty()) return out + "<p>No calibrations recorded.</p>\n" + html_page_end();
  out += "<h2>Calibrations (value ± U)</h2>\n" + calibration_table(cals, k);
  out += drift_section(find_drifts(h), k);
  out += "<h2>Parameters over time</h2>\n";
  for (int p = 0; p < kUnitParameterCount; ++p) {
    out += "<figure data-parameter=\"" + html_escape(parameter_name(p)) + "\">\n";
    out += plot::render_svg_inline(parameter_figure(h, cals, days, p),
                                   "parameter" + std::to_string(p));
    out += "\n<figcaption>" + html_escape(parameter_name(p)) + " (" + parameter_unit(p) +
           ") against days since " + html_escape(date_only(cals.front()->date_utc)) +
           " UTC; bars ±U.</figcaption>\n</figure>\n";
  }
  return out + html_page_end();
}

}  // namespace standcal::report
