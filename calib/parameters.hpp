#pragma once
// The nine unit parameters of model.md, in one fixed order shared by every estimator,
// report and JSON output. Internal values are in g, dimensionless and rad; reports
// show µg, ppm and arcsec.
#include <array>
#include <string_view>

#include "calib/units.hpp"

namespace standcal {

inline constexpr int kUnitParameterCount = 9;

enum UnitParameter : int {
  kBiasX = 0,
  kBiasY,
  kBiasZ,
  kScaleX,
  kScaleY,
  kScaleZ,
  kGamma12,
  kGamma13,
  kGamma23
};

// JSON / report names, e.g. "bias_x", "gamma13".
inline constexpr std::array<std::string_view, kUnitParameterCount> kUnitParameterNames{
    "bias_x", "bias_y", "bias_z", "scale_x", "scale_y", "scale_z", "gamma12", "gamma13", "gamma23"};

// Report unit of each parameter.
inline constexpr std::array<std::string_view, kUnitParameterCount> kUnitParameterUnits{
    "ug", "ug", "ug", "ppm", "ppm", "ppm", "arcsec", "arcsec", "arcsec"};

// Multiply an internal value (g, dimensionless, rad) by this to get its report unit.
inline constexpr double report_scale(int parameter) {
  return parameter < 3 ? 1.0 / kUg : parameter < 6 ? 1.0 / kPpm : kRadToArcsec;
}

}  // namespace standcal
