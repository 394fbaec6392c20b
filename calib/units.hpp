#pragma once
// Unit conversions used across the calibration maths. Values inside calib are SI or
// dimensionless (J in g, angles in rad); reports convert at the edge with these.
#include <limits>
#include <numbers>

namespace standcal {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;
inline constexpr double kArcsecToRad = kPi / (180.0 * 3600.0);
inline constexpr double kRadToArcsec = 1.0 / kArcsecToRad;
inline constexpr double kArcminToRad = kPi / (180.0 * 60.0);
inline constexpr double kUg = 1e-6;   // one micro-g, as a fraction of g
inline constexpr double kPpm = 1e-6;  // one part per million
inline constexpr double kStandardGravity_mps2 = 9.80665;
// "Not determined": a parameter the data cannot fix, a statistic with too few samples.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace standcal
