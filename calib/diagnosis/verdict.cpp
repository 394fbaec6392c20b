#include "calib/diagnosis/verdict.hpp"

#include <cmath>

#include "calib/identifiability.hpp"

namespace standcal::diagnosis {

std::string redundancy_shortfall(const Prepared& P) {
  const LinearProblem& lp = P.model->problem();
  // Positions the baseline cannot predict from the others (each alone fixes a parameter):
  // there the held-out check is impossible.
  int unpredictable = 0;
  for (Eigen::Index k = 0; k < P.base.press.size(); ++k)
    unpredictable += std::isfinite(P.base.press[k]) ? 0 : 1;
  // The unit's nine parameters come from the gravity projections; with no more positions
  // than that they are fitted exactly and the model cannot be checked (model.md, paper9).
  // A repeated orientation checks repeatability, not the model: count distinct ones.
  const int distinct = distinct_orientations(P.avg);
  if (P.base.dof <= 0) return "the fit has no redundancy";
  if (distinct - kUnitParameterCount <= 0)
    return positions_for_unknowns(P.avg, kUnitParameterCount) +
           ": the nine unit parameters rest on only " + std::to_string(distinct) +
           " distinct gravity projections, so they absorb any missing physics exactly";
  if (2 * unpredictable > lp.positions)
    return std::to_string(unpredictable) + " of " + std::to_string(lp.positions) +
           " positions cannot be predicted from the others (no held-out check)";
  if (2 * P.n_standing_out < static_cast<int>(P.cands.size()))
    return "only " + std::to_string(P.n_standing_out) + " of " + std::to_string(P.cands.size()) +
           " catalog candidates stand out from the calibration parameters";
  return "";
}

std::string verdict_of(const Diagnosis& d, bool ambiguous, const DiagnoseOptions& options) {
  if (ambiguous) return "ambiguous";
  if (d.findings.empty())
    return d.baseline_p > options.consistency_p ? "consistent" : "unexplained";
  return d.final_p > options.consistency_p ? "explained" : "unexplained";
}

}  // namespace standcal::diagnosis
