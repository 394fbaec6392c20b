#include "calib/diagnosis/position_context.hpp"

#include <cmath>

#include "calib/units.hpp"

namespace standcal::diagnosis {

std::vector<PositionContext> position_contexts(const std::vector<PositionAverage>& avg,
                                               double temp_ref_c) {
  std::vector<PositionContext> ctx;
  for (const PositionAverage& p : avg) {
    PositionContext c;
    c.up = p.up();
    c.alpha1_deg = p.alpha1_cmd_deg;
    c.alpha2_deg = p.alpha2_cmd_deg;
    c.mount = p.mount;
    c.t_mid_h = 0.5 * (p.t_start_s + p.t_end_s) / 3600.0;
    c.temp_delta_c = std::isfinite(p.temp_mean_c) ? p.temp_mean_c - temp_ref_c : 0.0;
    c.approach = p.approach;
    ctx.push_back(c);
  }
  return ctx;
}

Vec3 up_derivative(const PositionContext& p, bool outer) {
  const double a1 = p.alpha1_deg * kDegToRad, a2 = p.alpha2_deg * kDegToRad;
  const Vec3 d_table =
      outer ? Vec3(std::cos(a1), -std::sin(a1) * std::cos(a2), -std::sin(a1) * std::sin(a2))
            : Vec3(0, -std::cos(a1) * std::sin(a2), std::cos(a1) * std::cos(a2));
  return mount_permutation(p.mount) * d_table;
}

Vec3 level_derivative(const PositionContext& p, int level_axis) {
  const Vec3 d_base = -Vec3::Unit(level_axis).cross(Vec3::UnitY());
  return mount_permutation(p.mount) * C2(p.alpha2_deg * kDegToRad) * C1(p.alpha1_deg * kDegToRad) *
         d_base;
}

}  // namespace standcal::diagnosis
