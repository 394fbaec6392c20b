#pragma once
// Consistency, structure and location of the baseline's residuals (docs/diagnosis.md
// steps 2-3), and the residual table before and after.
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/diagnosis/residual_model.hpp"

namespace standcal::diagnosis {

// Trends of the normalised residuals per component against time, approach, u_i^2, u_i^3
// and (when recorded) temperature, as z-scores.
std::vector<StructureTest> structure_tests(const ResidualModel& model,
                                           const std::vector<PositionContext>& ctx, bool have_temp);

// Per component: chi2 and the positions beyond 3 sigma with the time span they cover.
std::vector<std::string> locate(const ResidualModel& model,
                                const std::vector<PositionAverage>& avg);

// Normalised residuals per position, before (the baseline) and after (the final fit).
std::vector<ResidualRow> residual_table(const std::vector<PositionAverage>& avg,
                                        const std::vector<PositionContext>& ctx,
                                        const LinearProblem& before, const LinearProblem& after);

}  // namespace standcal::diagnosis
