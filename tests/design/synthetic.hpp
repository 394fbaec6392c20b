#pragma once
// Per-position averages generated straight from the model of docs/model.md, with
// Gaussian noise of the stated standard error: fast Monte-Carlo input, no recording.
#include <random>
#include <vector>

#include "calib/full_estimator.hpp"
#include "calib/model.hpp"
#include "calib/position_average.hpp"
#include "calib/programs.hpp"
#include "calib/units.hpp"

namespace standcal::testing {

// One average per pose: J = model + N(0, sigma_g) per axis (sigma_g = 0: noise-free).
inline std::vector<PositionAverage> synthetic_averages(const std::vector<StandPose>& poses,
                                                       const UnitErrors& unit,
                                                       const StandErrors& stand, double sigma_g,
                                                       std::mt19937_64* rng = nullptr) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<PositionAverage> out;
  int index = 0;
  for (const auto& pose : poses) {
    PositionAverage pa;
    pa.pos = index++;
    pa.alpha1_cmd_deg = pose.alpha1_deg;
    pa.alpha2_cmd_deg = pose.alpha2_deg;
    pa.mount = pose.mount;
    const Vec3 u =
        true_up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad, pose.mount, stand);
    pa.mean_g = unit_output_g(unit, u);
    if (rng != nullptr)
      for (int a = 0; a < 3; ++a) pa.mean_g[a] += sigma_g * gauss(*rng);
    pa.standard_error_g = Vec3::Constant(sigma_g);
    pa.sigma_g = Vec3::Constant(sigma_g);
    pa.samples = 1000;
    out.push_back(pa);
  }
  return out;
}

// A realistic navigation-grade unit (model.md's typical magnitudes).
inline UnitErrors typical_unit() {
  UnitErrors u;
  u.bias_g = Vec3(50, -30, 80) * kUg;
  u.scale = Vec3(200, -150, 300) * kPpm;
  u.set_gamma_pair_sums_rad(Vec3(30, -20, 45) * kArcsecToRad);
  return u;
}

}  // namespace standcal::testing
