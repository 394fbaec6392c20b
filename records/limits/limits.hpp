#pragma once
// Acceptance limits per unit type and the conformity decision (issue 8), the way
// calibration labs state it (ILAC-G8:2019, guarded acceptance with guard band w = U):
// a parameter passes when |value| + U <= limit, fails when |value| - U > limit, and is
// otherwise INDETERMINATE, with U = k * sigma and k = 2 (about 95 % coverage).
// The config format and the rule in words: docs/certificate.md.
#include <array>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/parameters.hpp"
#include "calib/uncertainty_budget.hpp"

namespace standcal::records {

inline constexpr std::string_view kLimitsFormat = "standcal-limits/1";
inline constexpr double kDefaultCoverageFactor = 2.0;

// Limits of one unit parameter, in its report unit (µg, ppm, arcsec). Absent: not checked.
struct ParameterLimit {
  std::optional<double> max_abs;    // |value| must stay within this
  std::optional<double> max_sigma;  // the 1-sigma standard uncertainty must not exceed this
};

struct UnitTypeLimits {
  std::string unit_type;
  std::string description;
  std::array<ParameterLimit, kUnitParameterCount> parameters;  // calib/parameters.hpp order
  std::optional<double> max_chi2_dof;  // model check; only applied when the fit has redundancy
};

struct LimitsConfig {
  std::string source;  // file name, for messages
  double coverage_factor = kDefaultCoverageFactor;
  std::map<std::string, UnitTypeLimits> unit_types;

  // The limits of `unit_type`; an empty name picks the only type when there is exactly
  // one. Throws std::runtime_error listing the known types otherwise.
  const UnitTypeLimits& for_unit_type(const std::string& unit_type) const;
};

// Parses a standcal-limits/1 document. Throws std::runtime_error naming `source` and the
// key path, e.g. "limits.json: unit_types.QA-3000.parameters.bias.max_abs: must be a
// positive number (got -3)". Unknown keys are errors (a typo must not disable a limit).
LimitsConfig limits_from_json(const nlohmann::json& doc, const std::string& source);
LimitsConfig load_limits(const std::string& path);

enum class Outcome {
  pass,           // inside the limit even after allowing for the expanded uncertainty
  indeterminate,  // the limit lies within value ± U: conformity cannot be stated
  fail,           // outside the limit even after allowing for the expanded uncertainty
  not_evaluated,  // a limit is set but the quantity was not measured (unobservable, no redundancy)
  no_limit,       // no limit configured for this quantity
};

// "pass", "indeterminate", "fail", "not_evaluated", "no_limit" (stable: JSON, HTML).
std::string outcome_name(Outcome o);

// The decision on one value against a symmetric limit |value| <= limit (report units).
struct LimitDecision {
  Outcome outcome = Outcome::no_limit;
  double margin = 0;          // limit - |value|: room left by the value alone
  double guarded_margin = 0;  // limit - (|value| + U): room left after allowing for U (>= 0: pass)
  bool value_within_limit = true;  // for an indeterminate result: which side the value is on
};

// The rule itself, exposed so tests and callers can apply it to any number.
// Values equal to within 1e-9 of the limit count as equal (unit conversions round at
// ~1e-16 relative), so |value| + U == limit passes and |value| - U == limit is indeterminate.
inline constexpr double kLimitTolerance = 1e-9;  // relative to the limit
// A difference from the limit within that tolerance: none, under the rule.
bool negligible_against_limit(double difference, double limit);
LimitDecision decide(double value, double expanded_uncertainty, double limit);

struct ParameterConformity {
  int parameter = 0;                           // calib/parameters.hpp index
  std::string name;                            // "bias_x"
  std::string unit;                            // "ug"
  std::optional<double> value;                 // report units
  std::optional<double> sigma;                 // 1 sigma
  std::optional<double> expanded_uncertainty;  // U = k * sigma
  ParameterLimit limit;
  LimitDecision value_decision;               // |value| against max_abs
  Outcome sigma_outcome = Outcome::no_limit;  // sigma against max_sigma (pass/fail only)
  Outcome outcome = Outcome::no_limit;        // the parameter's combined outcome
  std::string explanation;                    // one sentence with the numbers
};

struct ModelCheckConformity {
  std::optional<double> chi2_dof;  // empty: no redundancy, not testable
  std::optional<double> max_chi2_dof;
  int redundancy = 0;
  Outcome outcome = Outcome::no_limit;
  std::string explanation;
};

struct ConformityReport {
  std::string unit_type;
  std::string limits_source;
  double coverage_factor = kDefaultCoverageFactor;
  bool with_budget = false;  // sigma = the budget's u_c, U its 95 % expanded uncertainty
  std::vector<ParameterConformity> parameters;  // all nine, in order
  ModelCheckConformity model_check;
  Outcome overall = Outcome::no_limit;  // pass, indeterminate or fail (no_limit: no limit set)
  std::string overall_text;             // the verdict in a sentence
};

// Applies `limits` to a fit. Overall verdict: FAIL when any check fails; otherwise
// INDETERMINATE when any parameter is indeterminate or a limited parameter could not be
// measured; otherwise PASS. A chi2/dof limit on a fit without redundancy is reported as
// not evaluated and does not change the verdict (the certificate says so).
// With a GUM budget, each parameter's sigma is the budget's combined u and U its expanded
// uncertainty (k from its effective degrees of freedom); without, U = coverage_factor sigma.
ConformityReport assess_conformity(const FitResult& fit, const UnitTypeLimits& limits,
                                   double coverage_factor = kDefaultCoverageFactor,
                                   const std::string& limits_source = {},
                                   const UncertaintyBudget* budget = nullptr);

// The decision rule in plain words, for the certificate.
// `budget`: U and sigma are the GUM budget's (k per parameter), not coverage_factor sigma.
std::string decision_rule_text(double coverage_factor, bool budget = false);

nlohmann::json conformity_to_json(const ConformityReport& report);

}  // namespace standcal::records
