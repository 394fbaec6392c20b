#pragma once
// One programme position reduced to the numbers the estimators use: the mean of its
// dwell samples, the standard error of that mean, and where the stand was.
#include <cstddef>
#include <vector>

#include "calib/model.hpp"
#include "calib/units.hpp"

namespace standcal {

struct PositionAverage {
  int pos = 0;                // recording's position index
  double alpha1_cmd_deg = 0;  // commanded stand angles
  double alpha2_cmd_deg = 0;
  Mount mount = Mount::x;
  Vec3 mean_g = Vec3::Zero();            // J: mean specific force / g, per axis
  Vec3 standard_error_g = Vec3::Zero();  // standard error of that mean, per axis (g)
  Vec3 sigma_g = Vec3::Zero();           // sample standard deviation, per axis (g)
  std::size_t samples = 0;               // samples used
  std::size_t outliers_rejected = 0;     // samples dropped by the outlier rule (any axis)
  double t_start_s = 0;                  // first and last sample time
  double t_end_s = 0;
  double t_arrive_s = 0;   // when the stand reported in position
  double temp_mean_c = 0;  // NaN when not measured
  int approach = +1;       // approach direction (model.md hysteresis rule)

  // The dwell's mid-time: when its mean is taken to have been measured (bias wander).
  double mid_time_s() const { return 0.5 * (t_start_s + t_end_s); }
  // The span its mean averages a slowly varying bias over.
  double span_s() const { return t_end_s - t_start_s; }
  // The commanded up-vector u(alpha1, alpha2) in instrument axes for this mount.
  Vec3 up() const;
};

}  // namespace standcal
