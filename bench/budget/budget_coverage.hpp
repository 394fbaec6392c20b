#pragma once
// Monte Carlo of the GUM budget's coverage (issue 20, docs/calibration.md "Uncertainty
// budget"): seeded calibrations whose stand errors, local gravity and temperature
// coefficients are drawn from the distributions the budget file states, measured with
// white noise on the dwell means by the forward model (calib/model.hpp, not the
// estimator), fitted, budgeted, and checked: does |estimate - truth| <= U hold in 95 %?
#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "calib/parameters.hpp"
#include "calib/programs.hpp"
#include "calib/uncertainty_budget.hpp"

namespace standcal::budget_mc {

struct Setup {
  std::string estimator = "joint";  // "joint" | "full"
  Program program;
  int runs = 1000;
  std::uint64_t first_seed = 1;
  BudgetConfig config;                    // the stated bounds: the budget's, and drawn from
  std::optional<BudgetConfig> draw_from;  // draw from these instead (a budget that omits some)
  std::string unit_type = "QA-2000";      // whose temperature coefficients apply
  double mean_error_ug = 3;               // white error of one dwell mean, per axis
  double temperature_start_c = 22;        // the run drifts linearly between these
  double temperature_end_c = 25;
  double g_used_mps2 = 9.81625;
  int threads = 2;
};

struct Coverage {
  std::array<double, kUnitParameterCount> covered{};       // share of runs with |error| <= U
  std::array<double, kUnitParameterCount> z2{};            // mean (error / u_c)^2
  std::array<double, kUnitParameterCount> type_b_share{};  // mean share of u_c^2 from type B
  std::array<double, kUnitParameterCount> mean_k{};
  int runs = 0;
  int failed = 0;
};

// Bounds like a lab's stand data sheet (docs/calibration.md gives them).
BudgetConfig data_sheet_config();

Coverage run_coverage(const Setup& setup);

}  // namespace standcal::budget_mc
