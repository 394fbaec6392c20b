// The conformity rule of records/limits: pass when |v| + U <= L, fail when |v| - U > L,
// indeterminate in between (U = 2 sigma), and a config whose every mistake is named.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "calib/units.hpp"
#include "records/limits/limits.hpp"

namespace standcal::records {
namespace {

using nlohmann::json;

json example_config() {
  return json::parse(R"({
    "format": "standcal-limits/1",
    "unit_types": {
      "QA-2000": {
        "description": "navigation-grade quartz unit",
        "parameters": {
          "bias":  {"max_abs": 100, "max_sigma": 10},
          "scale": {"max_abs": 300},
          "gamma": {"max_abs": 60, "max_sigma": 5},
          "bias_z": {"max_abs": 150}
        },
        "max_chi2_dof": 3
      }
    }
  })");
}

// A fit whose report-unit values and sigmas are given directly (µg, ppm, arcsec).
FitResult fit_with(const std::array<double, 9>& values, const std::array<double, 9>& sigmas,
                   int redundancy = 0, double chi2_dof = NAN) {
  FitResult fit;
  for (int p = 0; p < kUnitParameterCount; ++p) {
    fit.unit[static_cast<std::size_t>(p)].value =
        values[static_cast<std::size_t>(p)] / report_scale(p);
    fit.unit[static_cast<std::size_t>(p)].sigma =
        sigmas[static_cast<std::size_t>(p)] / report_scale(p);
  }
  fit.redundancy = redundancy;
  fit.chi2_dof = chi2_dof;
  return fit;
}

std::string config_error(const json& doc) {
  try {
    limits_from_json(doc, "lab-limits.json");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(LimitsDecide, ValuePlusUncertaintyExactlyAtTheLimitPasses) {
  const LimitDecision d = decide(80.0, 20.0, 100.0);
  EXPECT_EQ(d.outcome, Outcome::pass);
  EXPECT_DOUBLE_EQ(d.guarded_margin, 0.0);
  EXPECT_DOUBLE_EQ(d.margin, 20.0);
}

TEST(LimitsDecide, JustBeyondTheGuardedLimitIsIndeterminateNotPass) {
  EXPECT_EQ(decide(80.01, 20.0, 100.0).outcome, Outcome::indeterminate);
  EXPECT_EQ(decide(-80.01, 20.0, 100.0).outcome, Outcome::indeterminate);
}

TEST(LimitsDecide, ValueMinusUncertaintyExactlyAtTheLimitIsIndeterminate) {
  const LimitDecision d = decide(120.0, 20.0, 100.0);
  EXPECT_EQ(d.outcome, Outcome::indeterminate);
  EXPECT_FALSE(d.value_within_limit);
  EXPECT_EQ(decide(120.01, 20.0, 100.0).outcome, Outcome::fail);
}

TEST(LimitsDecide, SignDoesNotMatterOnlyMagnitude) {
  EXPECT_EQ(decide(-50, 10, 100).outcome, Outcome::pass);
  EXPECT_EQ(decide(-150, 10, 100).outcome, Outcome::fail);
  EXPECT_TRUE(decide(-95, 10, 100).value_within_limit);
  EXPECT_EQ(decide(-95, 10, 100).outcome, Outcome::indeterminate);
}

TEST(LimitsDecide, ValueExactlyAtTheLimitIsIndeterminateWhateverItsUncertainty) {
  EXPECT_EQ(decide(100, 0.5, 100).outcome, Outcome::indeterminate);
  EXPECT_TRUE(decide(100, 0.5, 100).value_within_limit);
  // A perfectly known value exactly at the limit conforms (|v| + 0 <= L).
  EXPECT_EQ(decide(100, 0, 100).outcome, Outcome::pass);
}

TEST(LimitsAssess, BoundaryAfterUnitConversionStillPasses) {
  // 80 µg ± 10 µg (U = 20 µg) against 100 µg, travelling through g and back.
  const LimitsConfig config = limits_from_json(example_config(), "lab-limits.json");
  const FitResult fit = fit_with({80, 0, 0, 0, 0, 0, 0, 0, 0}, {10, 1, 1, 1, 1, 1, 1, 1, 1});
  const ConformityReport r = assess_conformity(fit, config.for_unit_type("QA-2000"));
  EXPECT_EQ(r.parameters[0].value_decision.outcome, Outcome::pass);
  EXPECT_EQ(r.parameters[0].sigma_outcome, Outcome::pass);  // sigma 10 = max_sigma 10
  EXPECT_NEAR(*r.parameters[0].expanded_uncertainty, 20.0, 1e-9);
  EXPECT_EQ(r.overall, Outcome::pass);
}

TEST(LimitsAssess, EachOutcomeAndTheOverallVerdict) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("");
  // bias_x pass, bias_y indeterminate, bias_z (own limit 150) pass at 130 ± 5.
  FitResult fit =
      fit_with({50, -95, 130, 100, -200, 10, 20, -30, 5}, {5, 5, 5, 10, 10, 10, 2, 2, 2});
  ConformityReport r = assess_conformity(fit, limits);
  EXPECT_EQ(r.parameters[0].outcome, Outcome::pass);
  EXPECT_EQ(r.parameters[1].outcome, Outcome::indeterminate);
  EXPECT_EQ(r.parameters[2].outcome, Outcome::pass) << "bias_z overrides the group limit";
  EXPECT_EQ(r.overall, Outcome::indeterminate);
  EXPECT_NE(r.overall_text.find("INDETERMINATE"), std::string::npos);

  // gamma13 plainly outside: 70 ± 2 (U = 4) against 60.
  fit = fit_with({50, 10, 130, 100, -200, 10, 20, -70, 5}, {5, 5, 5, 10, 10, 10, 2, 2, 2});
  r = assess_conformity(fit, limits);
  EXPECT_EQ(r.parameters[kGamma13].outcome, Outcome::fail);
  EXPECT_LT(r.parameters[kGamma13].value_decision.guarded_margin, 0);
  EXPECT_EQ(r.overall, Outcome::fail);

  // Everything inside: pass.
  fit = fit_with({50, 10, 130, 100, -200, 10, 20, -30, 5}, {5, 5, 5, 10, 10, 10, 2, 2, 2});
  r = assess_conformity(fit, limits);
  EXPECT_EQ(r.overall, Outcome::pass);
  EXPECT_EQ(r.model_check.outcome, Outcome::not_evaluated)
      << "no redundancy: chi2 cannot be tested";
}

TEST(LimitsAssess, SigmaAboveItsLimitFailsEvenWhenTheValueIsSmall) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  const FitResult fit = fit_with({0, 0, 0, 0, 0, 0, 1, 1, 1}, {1, 1, 1, 1, 1, 1, 6, 1, 1});
  const ConformityReport r = assess_conformity(fit, limits);
  EXPECT_EQ(r.parameters[kGamma12].sigma_outcome, Outcome::fail);
  EXPECT_EQ(r.parameters[kGamma12].outcome, Outcome::fail);
  EXPECT_EQ(r.overall, Outcome::fail);
}

TEST(LimitsAssess, ModelCheckFailsWhenChi2PerDofExceedsTheLimit) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  EXPECT_EQ(assess_conformity(fit_with({}, {1, 1, 1, 1, 1, 1, 1, 1, 1}, 15, 4.2), limits)
                .model_check.outcome,
            Outcome::fail);
  EXPECT_EQ(assess_conformity(fit_with({}, {1, 1, 1, 1, 1, 1, 1, 1, 1}, 15, 4.2), limits).overall,
            Outcome::fail);
  EXPECT_EQ(assess_conformity(fit_with({}, {1, 1, 1, 1, 1, 1, 1, 1, 1}, 15, 1.1), limits).overall,
            Outcome::pass);
}

// What decides an outcome reads as deciding it: two decimals said "σ 5.00 arcsec EXCEEDS the
// allowed 5.00 arcsec", "chi2/dof 3.00 ... against the limit 3.00: the residuals exceed" and
// "outside even with the uncertainty subtracted, by 0.00".
TEST(LimitsAssess, AnOutcomeJustPastItsLimitIsSaidWithTheDigitsThatShowIt) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  // gamma12's sigma 5.004 against 5; gamma13 at 70.004 +- 5 (U = 10) against 60.
  const FitResult fit =
      fit_with({0, 0, 0, 0, 0, 0, 1, 70.004, 1}, {1, 1, 1, 1, 1, 1, 5.004, 5, 1}, 15, 3.001);
  const ConformityReport r = assess_conformity(fit, limits);
  ASSERT_EQ(r.parameters[kGamma12].sigma_outcome, Outcome::fail);
  EXPECT_NE(r.parameters[kGamma12].explanation.find("EXCEEDS the allowed 5.000 "),
            std::string::npos)
      << r.parameters[kGamma12].explanation;
  EXPECT_NE(r.parameters[kGamma12].explanation.find("σ 5.004 "), std::string::npos)
      << r.parameters[kGamma12].explanation;
  ASSERT_EQ(r.parameters[kGamma13].value_decision.outcome, Outcome::fail);
  // Every number at the decimals that show the decision: |v| - U past the limit.
  EXPECT_NE(r.parameters[kGamma13].explanation.find(
                "|70.004| ″ with U = 10.000 ″ (k = 2) against the limit 60.000 ″: outside even "
                "with the uncertainty subtracted, by 0.004 ″"),
            std::string::npos)
      << r.parameters[kGamma13].explanation;
  ASSERT_EQ(r.model_check.outcome, Outcome::fail);
  EXPECT_NE(r.model_check.explanation.find("chi2/dof 3.001 with 15 degrees of freedom against "
                                           "the limit 3.000: the residuals exceed"),
            std::string::npos)
      << r.model_check.explanation;
  // A pass keeps its two decimals; |v| + U at the limit within the rule's tolerance (through
  // report units and back) has none to spare, not 0.00000000000001.
  const FitResult inside =
      fit_with({0, 0, 0, 0, 0, 0, 0, 50, 0}, {1, 1, 1, 1, 1, 1, 5, 5, 1}, 15, 1.1);
  const ConformityReport ok = assess_conformity(inside, limits);
  EXPECT_NE(ok.parameters[kGamma12].explanation.find("σ 5.00 ″ within the allowed 5.00 ″"),
            std::string::npos)
      << ok.parameters[kGamma12].explanation;
  EXPECT_NE(ok.model_check.explanation.find("chi2/dof 1.10 with"), std::string::npos)
      << ok.model_check.explanation;
  ASSERT_EQ(ok.parameters[kGamma13].value_decision.outcome, Outcome::pass);
  EXPECT_NE(ok.parameters[kGamma13].explanation.find("|50.00| ″ with U = 10.00 ″ (k = 2) against "
                                                     "the limit 60.00 ″: inside even with the "
                                                     "uncertainty added, 0.00 ″ to spare"),
            std::string::npos)
      << ok.parameters[kGamma13].explanation;
}

TEST(LimitsAssess, UnmeasuredLimitedParameterMakesTheVerdictIndeterminate) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  FitResult fit = fit_with({}, {1, 1, 1, 1, 1, 1, 1, 1, 1});
  fit.unit[kGamma13] = ParameterEstimate{std::nullopt, std::nullopt, "no position with ux*uz != 0"};
  const ConformityReport r = assess_conformity(fit, limits);
  EXPECT_EQ(r.parameters[kGamma13].outcome, Outcome::not_evaluated);
  EXPECT_EQ(r.overall, Outcome::indeterminate);
  EXPECT_NE(r.parameters[kGamma13].explanation.find("ux*uz"), std::string::npos);
}

TEST(LimitsAssess, JsonCarriesTheRuleAndEveryOutcome) {
  const UnitTypeLimits limits = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  const json j = conformity_to_json(assess_conformity(
      fit_with({50, -95, 130, 0, 0, 0, 0, 0, 0}, {5, 5, 5, 1, 1, 1, 1, 1, 1}), limits));
  EXPECT_EQ(j["parameters"]["bias_y"]["outcome"], "indeterminate");
  EXPECT_EQ(j["parameters"]["bias_x"]["outcome"], "pass");
  EXPECT_NEAR(j["parameters"]["bias_x"]["guarded_margin"].get<double>(), 40.0, 1e-9);
  EXPECT_EQ(j["overall"], "indeterminate");
  EXPECT_NE(j["rule"].get<std::string>().find("ILAC-G8"), std::string::npos);
}

TEST(LimitsConfig, GroupAndAxisKeysMerge) {
  const UnitTypeLimits l = limits_from_json(example_config(), "x").for_unit_type("QA-2000");
  EXPECT_EQ(*l.parameters[kBiasZ].max_abs, 150);
  EXPECT_EQ(*l.parameters[kBiasZ].max_sigma, 10) << "the group's max_sigma is kept";
  EXPECT_EQ(*l.parameters[kScaleY].max_abs, 300);
  EXPECT_FALSE(l.parameters[kScaleY].max_sigma.has_value());
  EXPECT_EQ(*l.max_chi2_dof, 3);
}

TEST(LimitsConfig, BadConfigsAreNamedByKey) {
  json doc = example_config();
  doc["unit_types"]["QA-2000"]["parameters"]["bias"]["max_abs"] = -3;
  EXPECT_EQ(config_error(doc),
            "lab-limits.json: unit_types.QA-2000.parameters.bias.max_abs: must be a positive "
            "number (got -3)");

  doc = example_config();
  doc["unit_types"]["QA-2000"]["parameters"]["bais_x"] = json{{"max_abs", 1}};
  EXPECT_NE(config_error(doc).find("unit_types.QA-2000.parameters.bais_x: unknown parameter"),
            std::string::npos);

  doc = example_config();
  doc["unit_types"]["QA-2000"]["parameters"]["scale"]["max_abz"] = 1;
  EXPECT_NE(config_error(doc).find("unit_types.QA-2000.parameters.scale.max_abz: unknown key"),
            std::string::npos);

  doc = example_config();
  doc["unit_types"]["QA-2000"]["max_chi2_dof"] = "3";
  EXPECT_NE(config_error(doc).find("max_chi2_dof: must be a positive number (got \"3\")"),
            std::string::npos);

  doc = example_config();
  doc["format"] = "standcal-limits/2";
  EXPECT_NE(config_error(doc).find("lab-limits.json: format: must be \"standcal-limits/1\""),
            std::string::npos);

  doc = example_config();
  doc["unit_types"]["QA-2000"].erase("parameters");
  EXPECT_NE(config_error(doc).find("unit_types.QA-2000.parameters: missing"), std::string::npos);

  doc = example_config();
  doc["unit_types"] = json::object();
  EXPECT_NE(config_error(doc).find("unit_types: must name at least one unit type"),
            std::string::npos);
}

TEST(LimitsConfig, UnknownUnitTypeListsTheKnownOnes) {
  json doc = example_config();
  doc["unit_types"]["QA-3000"] = doc["unit_types"]["QA-2000"];
  const LimitsConfig config = limits_from_json(doc, "lab-limits.json");
  try {
    config.for_unit_type("QA-9");
    FAIL() << "an unknown unit type must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(),
                 "lab-limits.json: no limits for unit type 'QA-9' (known: QA-2000, QA-3000)");
  }
  EXPECT_THROW(config.for_unit_type(""), std::runtime_error) << "two types: the caller must choose";
}

TEST(LimitsConfig, MissingFileAndBadJsonNameTheFile) {
  EXPECT_THROW(
      {
        try {
          load_limits("/nonexistent/limits.json");
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("/nonexistent/limits.json"), std::string::npos);
          throw;
        }
      },
      std::runtime_error);
}

}  // namespace
}  // namespace standcal::records
