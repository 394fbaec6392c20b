// `standcal noise REC --plot allan.svg` (issue 3): the Allan deviation of each axis on
// log-log axes with the white-noise and bias-instability readings marked.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calib/allan.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "report/noise/allan_figure.hpp"

namespace standcal {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string g3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

// A static recording: one position, 20 minutes at 100 Hz, white noise plus a
// Gauss-Markov bias (so the curve has a floor to read the bias instability from).
Recording static_recording() {
  SimulationRequest req;
  ProgramPosition pos;
  req.program.name = "static";
  req.program.positions = {pos};
  req.truth = default_truth();
  req.truth.noise.density_ug_rthz = 10;
  req.truth.noise.bias_instability_ug = 2;
  req.truth.noise.bias_instability_tau_s = 60;
  req.timing.dwell_s = 1200;
  req.timing.settle_s = 0;
  req.seed = 7;
  return simulate_run(req);
}

TEST(NoisePlot, FigureMarksTheReadings) {
  report::AxisAllan a;
  a.axis = "x";
  for (double tau : {0.01, 0.1, 1.0, 10.0, 100.0})
    a.curve.push_back({tau, 10 / std::sqrt(tau) + 0.5, 100});
  a.figures.white_density = 10;
  a.figures.bias_instability = 3;
  a.figures.bias_instability_tau_s = 100;
  const plot::Figure fig = report::allan_figure({a}, "rec.csv");
  ASSERT_EQ(fig.panels.size(), 1u);
  const plot::Panel& p = fig.panels[0];
  EXPECT_TRUE(p.log_x);
  EXPECT_TRUE(p.log_y);
  ASSERT_EQ(p.series.size(), 3u);  // curve, white-noise line, bias-instability floor
  const plot::Series& white = p.series[1];
  // N/sqrt(tau) through the curve's tau range: N at tau = 1 s.
  EXPECT_NEAR(white.y.front() * std::sqrt(white.x.front()), 10.0, 1e-9);
  EXPECT_NEAR(white.y.back() * std::sqrt(white.x.back()), 10.0, 1e-9);
  const plot::Series& floor = p.series[2];
  for (double y : floor.y) EXPECT_NEAR(y, 0.664 * 3, 1e-12);
  EXPECT_NE(std::find(floor.x.begin(), floor.x.end(), 100.0), floor.x.end());
  EXPECT_THROW(report::allan_figure({}, "rec.csv"), std::runtime_error);
}

TEST(NoisePlot, CliDrawsEveryAxisWithItsReadings) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("standcal-noise-plot-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_recording(static_recording(), (dir / "static.csv").string());
  const std::string cmd = std::string(STANDCAL_CLI_PATH) + " noise " +
                          (dir / "static.csv").string() + " --json --plot " +
                          (dir / "allan.svg").string() + " > " + (dir / "noise.json").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string svg = read_text(dir / "allan.svg");
  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "noise.json"));
  ASSERT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  for (const char* axis : {"x", "y", "z"}) {
    EXPECT_NE(svg.find(std::string(axis) + " axis: Allan deviation of"), std::string::npos) << axis;
    EXPECT_NE(svg.find(std::string("Allan deviation ") + axis), std::string::npos)
        << axis;  // the series' legend
    // The readings the plot marks are the ones the command prints.
    const nlohmann::json& ax = j["axes"][axis];
    ASSERT_TRUE(ax["noise_density_ug_rthz"].is_number()) << axis;
    const double n = ax["noise_density_ug_rthz"].get<double>();
    EXPECT_NEAR(n, 10.0, 1.5) << axis;  // the simulated white noise
    EXPECT_NE(svg.find("white noise N = " + g3(n) + " ug/sqrt(Hz)"), std::string::npos) << axis;
    if (ax["bias_instability_ug"].is_number()) {
      EXPECT_NE(
          svg.find("bias instability B = " + g3(ax["bias_instability_ug"].get<double>()) + " ug"),
          std::string::npos)
          << axis;
    }
  }
  EXPECT_GE(
      [&] {
        std::size_t n = 0;
        for (std::size_t at = svg.find("tau (s)"); at != std::string::npos;
             at = svg.find("tau (s)", at + 1))
          ++n;
        return n;
      }(),
      3u);
  EXPECT_NE(svg.find("Allan deviation (ug)"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace standcal
