#pragma once
// The Allan deviation of each axis on log-log axes, with the noise figures read off it
// (calib/allan.hpp) drawn as the lines they stand for: the white-noise line N/sqrt(tau),
// the bias-instability floor 0.664 B at its tau, and the rate-random-walk line.
#include <string>
#include <vector>

#include "calib/allan.hpp"
#include "report/plot/figure.hpp"

namespace standcal::report {

struct AxisAllan {
  std::string axis;               // "x", "y", "z"
  std::vector<AllanPoint> curve;  // deviation in ug
  NoiseFigures figures;  // white_density ug/sqrt(Hz), bias_instability ug, random_walk ug/sqrt(s)
};

// One panel per axis, stacked. Throws std::runtime_error when `axes` is empty.
plot::Figure allan_figure(const std::vector<AxisAllan>& axes, const std::string& source);

}  // namespace standcal::report
