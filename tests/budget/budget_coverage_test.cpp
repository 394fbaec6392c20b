// Issue 20: a seeded subset of bench/budget's Monte Carlo. Calibrations whose stand errors,
// gravity and temperature coefficients are drawn from the bounds the budget states: the
// expanded U covers the true error in about 95 % of them (the bench runs 1000 per
// estimator and prints each figure; here 1000 runs of the invariant fit with other seeds,
// bounds 95 % +- 3.5 standard errors of that sample, +-2.4 %).
#include <gtest/gtest.h>

#include "bench/budget/budget_coverage.hpp"
#include "tests/support/statistical.hpp"

namespace standcal {
namespace {

// The bench's invariant-fit setup: paper9's poses twice, the data-sheet bounds, 1000 runs
// (about 2 s in a Release build).
budget_mc::Setup paper9_twice_setup() {
  budget_mc::Setup setup;
  setup.estimator = "joint";
  for (int round = 0; round < 2; ++round)
    for (const ProgramPosition& p : paper9().positions) setup.program.positions.push_back(p);
  setup.runs = 1000;
  setup.first_seed = 7;
  setup.config = budget_mc::data_sheet_config();
  return setup;
}

TEST(BudgetCoverage, ExpandedUncertaintyCoversTheTrueErrorIn95Percent) {
  STANDCAL_STATISTICAL_TEST();
  budget_mc::Setup setup = paper9_twice_setup();
  const budget_mc::Coverage c = budget_mc::run_coverage(setup);
  EXPECT_EQ(c.failed, 0);
  const double se = std::sqrt(0.95 * 0.05 / setup.runs);
  for (std::size_t j = 0; j < kUnitParameterCount; ++j) {
    EXPECT_NEAR(c.covered[j], 0.95, 3.5 * se) << kUnitParameterNames[j];
    EXPECT_NEAR(c.z2[j], 1.0, 0.3) << kUnitParameterNames[j];
  }
  // The type B part is not negligible where it should not be: gravity and temperature
  // carry about half the scale factors' variance at these bounds.
  for (std::size_t j = 3; j < 6; ++j) EXPECT_GT(c.type_b_share[j], 0.3) << kUnitParameterNames[j];
}

// Without the type B inputs the same runs are not covered: the budget is what makes U honest.
TEST(BudgetCoverage, TypeAAloneUndercoversTheScaleFactors) {
  STANDCAL_STATISTICAL_TEST();
  budget_mc::Setup setup = paper9_twice_setup();
  const BudgetConfig drawn = setup.config;
  setup.config = BudgetConfig{};  // budget nothing ...
  setup.draw_from = drawn;        // ... but draw the errors as before
  const budget_mc::Coverage c = budget_mc::run_coverage(setup);
  for (std::size_t j = 3; j < 6; ++j) EXPECT_LT(c.covered[j], 0.88) << kUnitParameterNames[j];
}

}  // namespace
}  // namespace standcal
