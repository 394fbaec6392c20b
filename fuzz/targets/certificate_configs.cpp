// The two files a lab writes for its certificates: acceptance limits (standcal-limits/1,
// records/limits/limits.hpp) and the uncertainty budget's bounds (standcal-budget/1,
// calib/uncertainty_budget.hpp). Byte 0 picks the reader (even: limits, odd: budget); the
// rest is the file's text, parsed as their loaders parse it.
//
// Properties: an accepted limits file has a positive finite coverage factor and positive
// finite limits, and every unit type it names decides a fit (one with a parameter
// unobservable) with the guarded-acceptance rule of docs/certificate.md — a parameter
// passes only where |value| + U <= limit — and serialises; an accepted budget has every
// bound finite and not negative, or absent (NaN).
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/uncertainty_budget.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"
#include "records/limits/limits.hpp"

namespace {

using standcal::fuzz::require;

bool positive(const std::optional<double>& v) { return !v || (std::isfinite(*v) && *v > 0); }

// A fit as the estimators report it: every parameter but gamma_23 observed.
standcal::FitResult sample_fit() {
  standcal::FitResult fit;
  fit.estimator = "joint";
  fit.redundancy = 3;
  fit.chi2_dof = 1.2;
  for (std::size_t i = 0; i < fit.unit.size(); ++i) {
    if (i == 8) {
      fit.unit[i].unobservable_reason = "not seen by this programme";
      continue;
    }
    fit.unit[i].value = (i < 3 ? 50e-6 : i < 6 ? 200e-6 : 1e-4) * (i % 2 ? -1.0 : 1.0);
    fit.unit[i].sigma = (i < 3 ? 5e-6 : i < 6 ? 10e-6 : 5e-6);
  }
  return fit;
}

void check_limits(const standcal::records::LimitsConfig& config) {
  using namespace standcal::records;
  require(std::isfinite(config.coverage_factor) && config.coverage_factor > 0,
          "limits: a coverage factor that is not a positive number");
  const standcal::FitResult fit = sample_fit();
  for (const auto& [name, type] : config.unit_types) {
    for (const ParameterLimit& l : type.parameters)
      require(positive(l.max_abs) && positive(l.max_sigma),
              "limits: unit type '" + name + "' accepted a limit that is not a positive number");
    require(positive(type.max_chi2_dof), "limits: a chi2/dof limit that is not positive");
    const ConformityReport r = assess_conformity(fit, type, config.coverage_factor, "fuzz");
    for (const ParameterConformity& p : r.parameters) {
      if (p.value_decision.outcome != Outcome::pass) continue;
      require(p.value && p.expanded_uncertainty && p.limit.max_abs &&
                  std::abs(*p.value) + *p.expanded_uncertainty <= *p.limit.max_abs * (1 + 1e-9),
              "limits: " + p.name + " passed with |value| + U beyond its limit");
    }
    (void)conformity_to_json(r).dump();
  }
}

void check_budget(const standcal::BudgetConfig& c) {
  const auto bound = [](double v) { return std::isnan(v) || (std::isfinite(v) && v >= 0); };
  require(bound(c.angle_zero_arcsec) && bound(c.orthogonality_arcsec) && bound(c.level_arcsec) &&
              bound(c.mounting_arcsec) && bound(c.remount_arcsec) &&
              bound(c.g_standard_uncertainty_mps2),
          "budget: a stand or gravity bound that is negative or not finite");
  for (const auto& [name, t] : c.unit_types)
    require(bound(t.bias_ug_per_c) && bound(t.scale_ppm_per_c),
            "budget: unit type '" + name + "' has a coefficient bound negative or not finite");
}

}  // namespace

int standcal_fuzz_certificate_configs(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const bool budget = data[0] & 1;
  const auto doc =
      nlohmann::json::parse(data + 1, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: both loaders refuse it before reading keys
  return standcal::fuzz::expect_only_runtime_errors("certificate_configs", [&] {
    if (budget)
      check_budget(standcal::budget_config_from_json(doc, "fuzz-budget.json"));
    else
      check_limits(standcal::records::limits_from_json(doc, "fuzz-limits.json"));
  });
}
