#pragma once
// The uncertainty budget of a calibration per the GUM (JCGM 100:2008) for each of the
// paper's nine parameters (docs/calibration.md, "Uncertainty budget"): type A, the fit's
// sigma from its noise model; type B, each stand, gravity, temperature and method input
// with a standard uncertainty from a data sheet or configuration, propagated through the
// estimator itself (sensitivities by evaluating the estimator on the measurements as that
// input would have changed them); combined standard uncertainty, Welch-Satterthwaite
// effective degrees of freedom, the coverage factor for 95 % and the expanded U.
#include <array>
#include <functional>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/distributions.hpp"
#include "calib/fit_result.hpp"
#include "calib/full_estimator.hpp"
#include "calib/parameters.hpp"
#include "calib/position_average.hpp"

namespace standcal {

inline constexpr const char* kBudgetFormat = "standcal-budget/1";

// The inputs' bounds as a lab states them (standcal-budget/1 file, docs/calibration.md).
// A bound left out (NaN) is not budgeted, and the budget says so.
struct BudgetConfig {
  std::string source;  // the file, for messages
  // The stand's data sheet: +- bounds, read as rectangular distributions.
  std::string stand_source;            // e.g. "two-axis stand TS-2, data sheet rev C"
  double angle_zero_arcsec = kNaN;     // each axis's angle-sensor zero
  double orthogonality_arcsec = kNaN;  // the inner axis against the outer, about y and z
  double level_arcsec = kNaN;          // the outer axis against the vertical, about x and z
  double mounting_arcsec = kNaN;       // the unit's seating in the fixture, about each axis
  // Each re-seating of the fixture on the stand, about each axis, independent per mount (a
  // re-mounted programme such as classic24: the full-vector fit with one rigid fixture takes
  // it into the gamma pair sums one for one, and cannot see it).
  double remount_arcsec = kNaN;
  // Local gravity: a standard uncertainty (normal), with where it comes from.
  double g_standard_uncertainty_mps2 = kNaN;
  std::string g_source;
  // The unit type's temperature coefficients: +- bounds (rectangular), per unit type.
  struct TemperatureCoefficients {
    double bias_ug_per_c = kNaN;
    double scale_ppm_per_c = kNaN;
  };
  std::map<std::string, TemperatureCoefficients> unit_types;
};

class BudgetConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads a standcal-budget/1 file; errors name the file and the key.
BudgetConfig load_budget_config(const std::string& path);
BudgetConfig budget_config_from_json(const nlohmann::json& doc, const std::string& source);

enum class Distribution { normal, rectangular };

// One type B input quantity.
struct BudgetInput {
  std::string name;    // "outer-axis angle zero"
  std::string source;  // where its bound comes from
  Distribution distribution = Distribution::rectangular;
  double stated = 0;                // the bound (rectangular) or the standard uncertainty
  std::string stated_unit;          // "arcsec", "m/s^2", "ug/degC", "ppm/degC"
  double to_internal = 1;           // stated unit -> internal (rad, m/s^2, g/degC, 1/degC)
  double standard_uncertainty = 0;  // internal units (rad, m/s^2, g/degC, 1/degC)
};

struct ParameterBudget {
  int parameter = 0;  // calib/parameters.hpp index
  bool observable = false;
  double type_a = 0;      // s of the fit (GUM's u_A), internal units
  double type_a_dof = 0;  // its degrees of freedom (infinite when not estimated)
  // Per input (same order as UncertaintyBudget::inputs): the sensitivity coefficient
  // (parameter per input, internal units), the contribution u_i = |c_i| u(x_i) plus the
  // second-order part, both internal units.
  std::vector<double> sensitivity;
  std::vector<double> second_order;  // half the second derivative times u^2: the bias it leaves
  std::vector<double> contribution;
  double combined = 0;         // u_c
  double dof_effective = 0;    // Welch-Satterthwaite
  double coverage_factor = 0;  // k for 95 %
  double expanded = 0;         // U = k u_c
};

struct UncertaintyBudget {
  std::string estimator;
  std::vector<BudgetInput> inputs;
  std::array<ParameterBudget, kUnitParameterCount> parameters;
  std::vector<std::string> not_budgeted;  // inputs without a stated bound, in words
  double coverage_probability = 0.95;
};

// The fit the budget propagates through: the certified estimator on (perturbed) averages.
using Estimator = std::function<FitResult(const std::vector<PositionAverage>&)>;

// The noise model a fit weighted with, as options that impose it.
FitNoiseOptions frozen_noise(const NoiseFinding& noise);
// The stand estimator `method` ("joint", "full", "paper-sequential") weighting as `nominal`
// did: the re-fits at +-u keep the nominal fit's noise model, so that a re-fit choosing
// another wander model does not show as a sensitivity that is not there.
Estimator budget_estimator(const std::string& method, const FitResult& nominal,
                           MountingModel mounting = MountingModel::common_fixture);

// The budget of `fit` (the estimator's result on `positions`, whose means are in units of
// g_local_mps2). `unit_type` picks the temperature coefficients.
UncertaintyBudget evaluate_budget(const std::vector<PositionAverage>& positions,
                                  const FitResult& fit, const Estimator& estimator,
                                  const BudgetConfig& config, const std::string& unit_type,
                                  double g_local_mps2);

nlohmann::json budget_to_json(const UncertaintyBudget& budget);
// The text report's lines: each parameter's u_c, nu_eff, k and U, and what is not budgeted.
std::string format_budget_summary(const UncertaintyBudget& budget);

}  // namespace standcal
