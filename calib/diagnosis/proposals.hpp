#pragma once
// Positions to add to a programme (docs/diagnosis.md step 7): where the candidates stand out
// from the calibration parameters, or where two rival explanations differ most. Every
// proposed pose lies inside the stand's limits.
#include <vector>

#include "calib/diagnosis/catalog.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/diagnosis/residual_model.hpp"
#include "calib/diagnosis/selection.hpp"

namespace standcal::diagnosis {

// Greedy choice of six reachable grid poses, each the one that most increases how far the
// catalog candidates stand out from the calibration parameters (sum of unabsorbed fractions).
std::vector<ProposedPosition> propose_for_redundancy(const ResidualModel& model,
                                                     const std::vector<PositionContext>& ctx,
                                                     const std::vector<Candidate>& cands,
                                                     Mount mount, const StandLimits& limits);

// Poses where the two rivals' predictions differ most, in sigma of one position's mean.
// None when the difference does not depend on the pose (they differ in time or temperature,
// not in angle).
struct Discrimination {
  std::vector<ProposedPosition> positions;
  bool no_pose_separates = false;
};
Discrimination propose_discriminating(const ResidualModel& model,
                                      const std::vector<PositionContext>& ctx,
                                      const Selection& selection, const Rivals& rivals, Mount mount,
                                      const StandLimits& limits);

}  // namespace standcal::diagnosis
