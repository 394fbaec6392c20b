// standcal-bench-allan-tau: how well a static recording's Allan curves pin the unit's
// correlation time (fit_gauss_markov_allan, what `standcal noise` reports and the fits take
// as --bias-instability-tau-s / --bias-instability-tau-max-s). For each case, seeded
// three-axis recordings of white noise (10 ug/rtHz) and a Gauss-Markov wander
// (simulate_static_gauss_markov): the fitted
// tau against the truth (median and 10-90 % of the ratio), the range's median width, how
// often the range is bounded, and how often it holds the truth (95 % would be exact); and the
// fitted size q against the truth (every axis: median and 10-90 %), what `standcal fit
// --bias-instability-ug` is then given, and how often each axis's q range holds the truth
// (of the axes of recordings that see a wander; 95 % would be exact) and its median width.
//   standcal-bench-allan-tau [--seeds 100] [--rate-hz 10]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "calib/allan.hpp"
#include "calib/simulator.hpp"

using namespace standcal;

namespace {

struct Case {
  double q_ug, tau_c_s, hours;
};

std::vector<std::vector<AllanPoint>> allan_curves(const std::vector<std::vector<double>>& axes,
                                                  double rate_hz) {
  std::vector<std::vector<AllanPoint>> curves;
  for (const std::vector<double>& y : axes)
    curves.push_back(overlapping_allan_deviation({y}, 1 / rate_hz));
  return curves;
}

double quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"How well a static recording's Allan curves pin the correlation time"};
  int seeds = 100;
  double rate_hz = 10;
  app.add_option("--seeds", seeds, "recordings per case")->capture_default_str();
  app.add_option("--rate-hz", rate_hz, "sample rate of the recordings")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const std::vector<Case> cases{{3, 60, 2},   {3, 300, 2}, {3, 1200, 2}, {1, 300, 2},
                                {10, 300, 2}, {3, 300, 8}, {3, 1200, 8}};
  std::printf("white 10 ug/rtHz at %.0f Hz, %d seeded three-axis recordings per case\n", rate_hz,
              seeds);
  std::printf("%6s %8s %6s  %22s %12s %8s %8s %8s %12s  %s  %s  %s\n", "q ug", "tau_c s", "hours",
              "tau/truth med (10-90%)", "range width", "bounded", "holds", "short", "dev/dof max",
              "q/truth med (10-90%)", "q range holds", "q width");
  const auto start = std::chrono::steady_clock::now();
  for (const Case& c : cases) {
    std::vector<double> ratio, width, q_ratio, q_width;
    int bounded = 0, holds = 0, short_correlation = 0, q_axes = 0, q_holds = 0;
    double worst_deviance_per_dof = 0;
    for (int s = 1; s <= seeds; ++s) {
      const auto fit = fit_gauss_markov_allan(
          allan_curves(simulate_static_gauss_markov(10, c.q_ug, c.tau_c_s, c.hours * 3600, rate_hz,
                                                    static_cast<unsigned>(s)),
                       rate_hz),
          1 / rate_hz);
      if (!fit) continue;
      ratio.push_back(fit->tau_s / c.tau_c_s);
      for (double q_ug : fit->q) q_ratio.push_back(q_ug / c.q_ug);
      for (std::size_t a = 0; a < fit->q_min.size(); ++a) {
        ++q_axes;
        q_holds += fit->q_min[a] <= c.q_ug && c.q_ug <= fit->q_max[a];
        q_width.push_back(fit->q_max[a] / fit->q_min[a]);
      }
      width.push_back(fit->tau_max_s / fit->tau_min_s);
      bounded += fit->tau_bounded;
      holds += fit->tau_min_s <= c.tau_c_s && c.tau_c_s <= fit->tau_max_s;
      short_correlation += fit->short_correlation;
      worst_deviance_per_dof = std::max(worst_deviance_per_dof, fit->deviance_per_dof);
    }
    std::printf(
        "%6.1f %8.0f %6.1f  %6.2f (%5.2f-%6.2f) %11.1fx %4d/%-3d %4d/%-3d %4d/%-3d %12.2f  %5.2f "
        "(%4.2f-%4.2f)  %5d/%-5d  %7.2fx\n",
        c.q_ug, c.tau_c_s, c.hours, quantile(ratio, 0.5), quantile(ratio, 0.1),
        quantile(ratio, 0.9), quantile(width, 0.5), bounded, seeds, holds, seeds, short_correlation,
        seeds, worst_deviance_per_dof, quantile(q_ratio, 0.5), quantile(q_ratio, 0.1),
        quantile(q_ratio, 0.9), q_holds, q_axes,
        q_width.empty() ? std::nan("") : quantile(q_width, 0.5));
  }
  std::printf("%.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}
