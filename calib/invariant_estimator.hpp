#pragma once
// The paper's invariant method: delta_J_L = h(u) . X + noise (model.md eq. 22), fitted
// (a) by the paper's three-step sequential procedure, or (b) jointly by weighted least
// squares over all positions. Weights come from each position's standard errors.
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/noise_model.hpp"
#include "calib/position_average.hpp"

namespace standcal {

// Standard error of delta_J_L at a position: the per-axis standard errors projected on
// u (axes independent), floored so noise-free data still gets finite weights.
double invariant_sigma_g(const PositionAverage& p);
inline constexpr double kInvariantSigmaFloor_g = 1e-10;

// One weighted least-squares fit of the nine parameters. Parameters the programme cannot
// observe are reported empty with the reason; the rest are fitted.
// Dwell means close in time share bias wander: with `noise` (by default estimated from the
// run) they are weighted by the covariance it implies (generalised least squares).
FitResult fit_invariant_joint(const std::vector<PositionAverage>& positions);
FitResult fit_invariant_joint(const std::vector<PositionAverage>& positions,
                              const FitNoiseOptions& noise);

// The paper's sequential procedure: step 1 the alpha2 = 0 positions (bias x, y, scale
// x, y, gamma12), step 2 the alpha1 = 0 positions (bias z, scale z, gamma23, after
// subtracting the known y terms), step 3 the rest (gamma13); each mean weighted as
// independent (the paper's procedure, white noise). Throws std::runtime_error
// when the programme does not have that structure.
FitResult fit_paper_sequential(const std::vector<PositionAverage>& positions);

}  // namespace standcal
