#include "report/noise/allan_figure.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace standcal::report {

namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The white-noise line of the convention in calib/allan.hpp: N read at tau = 1 s.
plot::Series white_noise_line(double density_ug_rthz, double tau_lo_s, double tau_hi_s) {
  plot::Series s{"white noise N = " + fmt("%.3g", density_ug_rthz) + " ug/sqrt(Hz): N/sqrt(tau)",
                 {},
                 {},
                 {},
                 plot::SeriesStyle::line};
  for (double tau : {tau_lo_s, tau_hi_s}) {
    s.x.push_back(tau);
    s.y.push_back(density_ug_rthz / std::sqrt(tau));
  }
  return s;
}

// The bias-instability floor: the curve's flat minimum, 0.664 B, at the tau it was read.
plot::Series bias_instability_mark(double bias_ug, double tau_s, double tau_lo_s, double tau_hi_s) {
  plot::Series s{"bias instability B = " + fmt("%.3g", bias_ug) + " ug (floor 0.664 B at tau " +
                     fmt("%.3g", tau_s) + " s)",
                 {std::max(tau_s / 4, tau_lo_s), tau_s, std::min(tau_s * 4, tau_hi_s)},
                 {0.664 * bias_ug, 0.664 * bias_ug, 0.664 * bias_ug},
                 {},
                 plot::SeriesStyle::points_and_line};
  return s;
}

// The rate-random-walk line, K read at tau = 3 s.
plot::Series random_walk_line(double k_ug_rts, double tau_lo_s, double tau_hi_s) {
  plot::Series s{"rate random walk K = " + fmt("%.3g", k_ug_rts) + " ug/sqrt(s): K sqrt(tau/3)",
                 {},
                 {},
                 {},
                 plot::SeriesStyle::line};
  for (double tau : {tau_lo_s, tau_hi_s}) {
    s.x.push_back(tau);
    s.y.push_back(k_ug_rts * std::sqrt(tau / 3.0));
  }
  return s;
}

plot::Panel axis_panel(const AxisAllan& a, const std::string& source) {
  plot::Panel panel;
  panel.title = a.axis + " axis: Allan deviation of " + source;
  panel.x_label = "tau (s)";
  panel.y_label = "Allan deviation (ug)";
  panel.log_x = true;
  panel.log_y = true;
  plot::Series curve{"Allan deviation " + a.axis, {}, {}, {}, plot::SeriesStyle::points_and_line};
  for (const AllanPoint& p : a.curve) {
    curve.x.push_back(p.tau_s);
    curve.y.push_back(p.deviation);
  }
  panel.series.push_back(curve);
  if (a.curve.empty()) return panel;
  const double tau_lo = a.curve.front().tau_s, tau_hi = a.curve.back().tau_s;
  if (a.figures.white_density)
    panel.series.push_back(white_noise_line(*a.figures.white_density, tau_lo, tau_hi));
  if (a.figures.bias_instability)
    panel.series.push_back(bias_instability_mark(*a.figures.bias_instability,
                                                 a.figures.bias_instability_tau_s, tau_lo, tau_hi));
  // The random walk rises from the long-tau end; over two decades it is seen where it matters.
  if (a.figures.random_walk)
    panel.series.push_back(
        random_walk_line(*a.figures.random_walk, std::max(tau_lo, tau_hi / 100), tau_hi));
  return panel;
}

}  // namespace

plot::Figure allan_figure(const std::vector<AxisAllan>& axes, const std::string& source) {
  if (axes.empty()) throw std::runtime_error("noise plot: no axis to draw for " + source);
  plot::Figure fig;
  fig.panel_height_px = 320;
  for (const AxisAllan& a : axes) fig.panels.push_back(axis_panel(a, source));
  return fig;
}

}  // namespace standcal::report
