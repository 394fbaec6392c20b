#pragma once
// How far a stand axis may turn, and which of an angle's equivalents (± whole turns) it
// takes: one type and one convention for the programmes (calib/programs), the stand
// drivers (drivers/stand) and the daemon's configuration (docs/standcald.json.md).
#include <cstdint>
#include <optional>

namespace standcal {

// Of the equivalent angles inside a range wider than a turn, which one a move goes to.
enum class CableWrap : std::uint8_t {
  nearest,  // the one nearest the axis now (the shortest move)
  centred,  // the one nearest the middle of the range (the cables kept unwound)
};

// A continuous axis (slip ring) turns freely; a limited one (cables) stays inside
// [min_deg, max_deg]. The default is the cautious one, a limited ±180° axis: a stand
// whose range nobody configured is not wound past its cables.
struct AxisRange {
  bool continuous = false;
  double min_deg = -180.0;  // only for a limited axis
  double max_deg = 180.0;   // only for a limited axis
  CableWrap cable_wrap = CableWrap::nearest;

  static AxisRange continuous_axis() { return {true, -180.0, 180.0, CableWrap::nearest}; }
  double middle_deg() const { return 0.5 * (min_deg + max_deg); }
};

// The angle folded into [-180, 180), exactly for every finite angle (1e308 gives -64:
// std::remainder is exact where a - 360 * floor(a / 360) loses every digit).
double wrap_deg(double angle_deg);

// The equivalent of angle_deg (± whole turns) that the axis takes: on a continuous axis
// wrap_deg(angle_deg); on a limited axis the equivalent inside the range (edges within
// 1e-9°) nearest reference_deg. Empty for an angle that is not finite or has no
// equivalent inside the range.
std::optional<double> equivalent_angle_deg(const AxisRange& range, double angle_deg,
                                           double reference_deg);

}  // namespace standcal
