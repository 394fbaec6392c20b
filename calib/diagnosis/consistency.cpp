#include "calib/diagnosis/consistency.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <utility>

#include "calib/diagnosis/words.hpp"

namespace standcal::diagnosis {

namespace {

// The trend of y against x, in sigma units (about N(0, 1) for pure noise).
double trend_z(const std::vector<double>& x, const std::vector<double>& y) {
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * y[i];
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  return sxx > 0 ? sxy / std::sqrt(sxx) : 0.0;
}

}  // namespace

std::vector<StructureTest> structure_tests(const ResidualModel& model,
                                           const std::vector<PositionContext>& ctx,
                                           bool have_temp) {
  const LinearProblem& lp = model.problem();
  std::vector<StructureTest> out;
  for (int a = 0; a < model.rows_per_position(); ++a) {
    std::vector<std::pair<std::string, std::function<double(const PositionContext&)>>> vars = {
        {"time", [](const PositionContext& p) { return p.t_mid_h; }},
        {"approach", [](const PositionContext& p) { return static_cast<double>(p.approach); }},
        {"angle_u2", [a](const PositionContext& p) { return p.up[a] * p.up[a]; }},
        {"angle_u3", [a](const PositionContext& p) { return p.up[a] * p.up[a] * p.up[a]; }}};
    if (have_temp)
      vars.push_back({"temperature", [](const PositionContext& p) { return p.temp_delta_c; }});
    for (const auto& [name, f] : vars) {
      std::vector<double> x, y;
      for (std::size_t r = 0; r < lp.row_component.size(); ++r)
        if (lp.row_component[r] == a) {
          x.push_back(f(ctx[static_cast<std::size_t>(lp.row_position[r])]));
          y.push_back(lp.y[static_cast<Eigen::Index>(r)]);
        }
      out.push_back({model.component_name(a), name, trend_z(x, y)});
    }
  }
  return out;
}

std::vector<std::string> locate(const ResidualModel& model,
                                const std::vector<PositionAverage>& avg) {
  const LinearProblem& lp = model.problem();
  std::vector<std::string> out;
  for (int a = 0; a < model.rows_per_position(); ++a) {
    double chi2 = 0;
    int n = 0;
    std::vector<int> flagged;
    double t0 = 1e300, t1 = -1e300;
    for (std::size_t r = 0; r < lp.row_component.size(); ++r) {
      if (lp.row_component[r] != a) continue;
      const double v = lp.y[static_cast<Eigen::Index>(r)];
      chi2 += v * v;
      ++n;
      if (std::abs(v) > 3) {
        const auto& p = avg[static_cast<std::size_t>(lp.row_position[r])];
        flagged.push_back(p.pos);
        t0 = std::min(t0, p.t_start_s);
        t1 = std::max(t1, p.t_end_s);
      }
    }
    std::string s = model.component_words(a) + ": chi2 " + fmt("%.1f", chi2) + " over " +
                    std::to_string(n) + " positions";
    if (!flagged.empty()) {
      s += "; residuals beyond 3 sigma at positions";
      for (int p : flagged) {
        s += ' ';
        s += std::to_string(p);
      }
      s += " (t = " + fmt("%.0f", t0) + " .. " + fmt("%.0f", t1) + " s)";
    } else {
      s += "; no position beyond 3 sigma";
    }
    out.push_back(s);
  }
  return out;
}

std::vector<ResidualRow> residual_table(const std::vector<PositionAverage>& avg,
                                        const std::vector<PositionContext>& ctx,
                                        const LinearProblem& before, const LinearProblem& after) {
  std::vector<ResidualRow> out;
  for (std::size_t k = 0; k < avg.size(); ++k) {
    ResidualRow row{avg[k].pos,
                    avg[k].alpha1_cmd_deg,
                    avg[k].alpha2_cmd_deg,
                    ctx[k].t_mid_h * 3600,
                    avg[k].temp_mean_c,
                    avg[k].approach,
                    {},
                    {}};
    for (std::size_t r = 0; r < before.row_position.size(); ++r)
      if (before.row_position[r] == static_cast<int>(k)) {
        // Per-dwell whitening: what a person reads as "sigma" (decorrelated rows would mix
        // positions).
        row.before.push_back(before.y_white[static_cast<Eigen::Index>(r)]);
        row.after.push_back(after.y_white[static_cast<Eigen::Index>(r)]);
      }
    out.push_back(row);
  }
  return out;
}

}  // namespace standcal::diagnosis
