#pragma once
// What a fit or a model check needs before any decomposition runs. Degenerate input (no
// position, too few distinct orientations, nothing observable) is refused with one error
// that says what was there and what was needed, instead of reaching Eigen with an empty
// or rank-zero system (issue 14: an empty QR segfaulted the daemon).
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/position_average.hpp"

namespace standcal {

// "cannot fit: ..." / "cannot check the model: ...": degenerate input for an estimator or
// the diagnosis. A std::runtime_error, like every documented rejection of bad input.
class CannotFit : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Orientations that differ: two positions on the same mount whose commanded up vectors
// agree to 1e-9 are one orientation seen twice (a repeat checks repeatability, it does not
// add an equation for the unit's parameters).
int distinct_orientations(const std::vector<PositionAverage>& positions);

// "3 positions (2 distinct orientations) for 9 unknowns": the words every refusal uses.
std::string positions_for_unknowns(const std::vector<PositionAverage>& positions, int unknowns);

// Throws CannotFit ("REFUSAL: 0 positions for 9 unknowns", "REFUSAL: position 3 has a mean
// or standard error that is not a finite number") unless there are positions and every
// one's numbers are finite: a NaN reaching a decomposition poisons every estimate without
// an error. `refusal` is "cannot fit (joint)", "cannot check the model", ...
void require_positions(const std::vector<PositionAverage>& positions, const std::string& refusal);

}  // namespace standcal
