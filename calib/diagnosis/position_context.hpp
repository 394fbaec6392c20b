#pragma once
// What the diagnosis knows about one position besides its mean: where the stand was, when,
// at which temperature and from which direction it came. Catalog terms are functions of it.
#include <vector>

#include "calib/model.hpp"
#include "calib/position_average.hpp"

namespace standcal::diagnosis {

inline constexpr const char* kAxisNames[3] = {"x", "y", "z"};

struct PositionContext {
  Vec3 up = Vec3::Zero();
  double alpha1_deg = 0, alpha2_deg = 0;  // commanded
  Mount mount = Mount::x;
  double t_mid_h = 0;
  double temp_delta_c = 0;  // T - temp_ref
  int approach = 1;
};

// One context per position average; temperatures referenced to temp_ref_c (0 where the
// recording has none).
std::vector<PositionContext> position_contexts(const std::vector<PositionAverage>& avg,
                                               double temp_ref_c);

// d u / d alpha_k (per rad) at a commanded pose, in instrument axes (model.md's u).
Vec3 up_derivative(const PositionContext& p, bool outer);

// d u / d epsilon (per rad) for the stand's levelling error about x_S (level_axis 0) or z_S
// (level_axis 2) at a commanded pose, in instrument axes: model.md's C_eps to first order,
// C_eps e_y = e_y - eps x e_y, carried through C1, C2 and the mount. Perpendicular to u.
Vec3 level_derivative(const PositionContext& p, int level_axis);

}  // namespace standcal::diagnosis
