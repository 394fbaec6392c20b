#pragma once
// Shared helpers of the calib tests: simulate, average and fit in one call.
#include <string>
#include <vector>

#include "calib/averaging.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/simulator.hpp"

namespace standcal::test {

#ifdef STANDCAL_TEST_DATA
// imu_tk's Xsens recording, vendored with its licence (tests/calib/data/imu_tk_xsens/).
inline const std::string kXsens = std::string(STANDCAL_TEST_DATA) + "/imu_tk_xsens/xsens_acc.mat";
#endif

// A truth with no noise at all: the estimators must then be exact up to model order.
inline TruthModel noise_free(TruthModel t) {
  t.noise = NoiseModel{};
  t.noise.density_ug_rthz = 0;
  t.temperature.noise_c = 0;
  return t;
}

// A simulated run of the default unit as `standcal simulate --program P --dwell-s D
// --rate-hz R --seed S` records it.
inline Recording simulate_default_run(const Program& program, double dwell_s, double sample_rate_hz,
                                      std::uint64_t seed = 1) {
  SimulationRequest req;
  req.program = program;
  req.truth = default_truth();
  req.timing.dwell_s = dwell_s;
  req.timing.sample_rate_hz = sample_rate_hz;
  req.seed = seed;
  return simulate_run(req);
}

inline std::vector<PositionAverage> simulate_averages(const Program& program,
                                                      const TruthModel& truth,
                                                      std::uint64_t seed = 1, double dwell_s = 2) {
  SimulationRequest req;
  req.program = program;
  req.truth = truth;
  req.seed = seed;
  req.timing.dwell_s = dwell_s;
  return average_positions(simulate_run(req));
}

// The nine true parameters in estimator units (g, dimensionless, rad; gamma pair sums).
inline Eigen::Matrix<double, 9, 1> true_parameters(const UnitErrors& u) {
  Eigen::Matrix<double, 9, 1> x;
  x << u.bias_g, u.scale, u.gamma_pair_sums_rad();
  return x;
}

inline Program program_of(const std::string& name, std::vector<std::pair<double, double>> angles) {
  Program p;
  p.name = name;
  for (const auto& [a1, a2] : angles) {
    ProgramPosition pos;
    pos.alpha1_deg = a1;
    pos.alpha2_deg = a2;
    p.positions.push_back(pos);
  }
  return p;
}

// 18 positions spread over the sphere: redundancy 9 for the invariant model.
inline Program redundant18() {
  std::vector<std::pair<double, double>> a;
  for (double a1 : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0}) a.emplace_back(a1, 0.0);
  for (double a2 : {45.0, 100.0, 160.0, 230.0, 290.0}) a.emplace_back(0.0, a2);
  for (double a1 : {30.0, 135.0, 225.0, 315.0})
    for (double a2 : {60.0}) a.emplace_back(a1, a2);
  a.emplace_back(45.0, 90.0);
  a.emplace_back(-45.0, 150.0);
  a.emplace_back(150.0, -120.0);
  return program_of("redundant18", a);
}

}  // namespace standcal::test
