// A certificate rendered from a simulated, finished run and read back by an HTML parser:
// traceability, each parameter's value ± U against an independent fit, the pass /
// indeterminate / fail marks from limits chosen around the measured values, the rule,
// the plots and the diagnosis.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/noise_model.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "report/certificate/certificate.hpp"
#include "tests/certificate/certificate_support.hpp"
#include "tests/certificate/html_query.hpp"
#include "tests/support/unit_static_recording.hpp"

namespace standcal::test {
namespace {

using nlohmann::json;
using report::CertificateRequest;

constexpr const char* kRunId = "20261121T223638Z-AU-0042";

std::string row(const std::string& parameter) {
  return "//table[@id='parameters']//tr[@data-parameter='" + parameter + "']";
}

double number_in(std::string text) {
  for (const char* junk : {"±", " "}) {
    for (std::size_t at; (at = text.find(junk)) != std::string::npos;)
      text.erase(at, std::string(junk).size());
  }
  return std::stod(text);
}

class CertificateOfSimulatedRun : public ::testing::Test {
 protected:
  void SetUp() override {
    rec_ = simulated_recording("AU-0042", default_truth(), 7);
    run_dir_ = write_done_run(state_.path(), kRunId, rec_);
    reference_ = fit_invariant_joint(average_positions(rec_));
  }

  // Report-unit value and sigma of the independent fit.
  double value(int p) const {
    return *reference_.unit[static_cast<std::size_t>(p)].value * report_scale(p);
  }
  double sigma(int p) const {
    return *reference_.unit[static_cast<std::size_t>(p)].sigma * report_scale(p);
  }

  // Limits placed around the measured values so that each outcome must appear:
  // bias_x well inside (pass), bias_y at |value| (inside, but within U: indeterminate),
  // bias_z below |value| - U (fail), scale_x sigma limit at half its sigma (fail).
  std::string write_limits() const {
    const json limits{
        {"format", "standcal-limits/1"},
        {"unit_types",
         {{"QA-2000",
           {{"description", "test unit"},
            {"parameters",
             {{"bias_x", {{"max_abs", std::abs(value(kBiasX)) + 2 * sigma(kBiasX) + 5}}},
              {"bias_y", {{"max_abs", std::abs(value(kBiasY)) + 0.5 * sigma(kBiasY)}}},
              {"bias_z", {{"max_abs", std::abs(value(kBiasZ)) - 2 * sigma(kBiasZ) - 5}}},
              {"scale_x", {{"max_abs", 1000}, {"max_sigma", sigma(kScaleX) / 2}}},
              {"gamma", {{"max_abs", 60}}}}}}}}}};
    const std::filesystem::path path = state_.file("limits.json");
    write_text(path, limits.dump(2));
    return path.string();
  }

  CertificateRequest request() const {
    CertificateRequest r;
    r.state_dir = state_.path();
    r.run_id = kRunId;
    return r;
  }

  TempDir state_;
  Recording rec_;
  std::filesystem::path run_dir_;
  FitResult reference_;
};

TEST_F(CertificateOfSimulatedRun, CarriesTheTraceability) {
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(request())));
  auto field = [&](const std::string& id) {
    return page.text("//dl[@id='traceability']/dd[@data-field='" + id + "']");
  };
  EXPECT_EQ(field("unit_serial"), "AU-0042");
  EXPECT_EQ(field("stand_id"), "stand-B2");
  EXPECT_EQ(field("operator"), "I. Petrova");
  EXPECT_EQ(field("config_hash"), "sha256:5f2c9a");
  EXPECT_EQ(field("software_version"), "0.1.0");
  EXPECT_EQ(field("g_source"), "gravimetric survey 2024, pillar 3");
  EXPECT_EQ(field("run_id"), kRunId);
  EXPECT_NE(field("date").find("2026-11-21T22:36:38Z"), std::string::npos);
  EXPECT_NE(field("g_local").find("9.81625"), std::string::npos);
  EXPECT_EQ(page.count("//table[@id='positions']//tr[td]"), 9u) << "one row per programme position";
  EXPECT_NE(page.text("//h1").find("AU-0042"), std::string::npos);
  EXPECT_EQ(page.count("//div[@class='howto']"), 1u) << "the newcomer's reading guide";
}

TEST_F(CertificateOfSimulatedRun, ShowsEveryParameterAsValuePlusMinusExpandedUncertainty) {
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(request())));
  ASSERT_EQ(page.count("//table[@id='parameters']//tr[@data-parameter]"), 9u);
  for (int p = 0; p < kUnitParameterCount; ++p) {
    const std::string name(kUnitParameterNames[static_cast<std::size_t>(p)]);
    SCOPED_TRACE(name);
    // Printed with 2 decimals: equal to the independent fit within rounding.
    EXPECT_NEAR(number_in(page.text(row(name) + "/td[contains(@class,'value')]")), value(p), 0.006);
    EXPECT_NEAR(number_in(page.text(row(name) + "/td[contains(@class,'U')]")), 2 * sigma(p), 0.006);
  }
  // Without limits: no verdict, every row "no limit".
  EXPECT_EQ(page.text("//*[@id='verdict']/@data-outcome"), "no_limit");
  EXPECT_EQ(page.count("//table[@id='parameters']//tr[@data-outcome='no_limit']"), 9u);
}

TEST_F(CertificateOfSimulatedRun, MarksEachOutcomeByTheStatedRule) {
  CertificateRequest r = request();
  r.limits_path = write_limits();
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(r)));
  EXPECT_EQ(page.text(row("bias_x") + "/@data-outcome"), "pass");
  EXPECT_EQ(page.text(row("bias_y") + "/@data-outcome"), "indeterminate");
  EXPECT_EQ(page.text(row("bias_z") + "/@data-outcome"), "fail");
  EXPECT_EQ(page.text(row("scale_x") + "/@data-outcome"), "fail") << "sigma above its limit";
  EXPECT_EQ(page.text(row("scale_y") + "/@data-outcome"), "no_limit");
  EXPECT_EQ(page.text(row("gamma12") + "/@data-outcome"), "pass");
  EXPECT_EQ(page.text(row("bias_x") + "/td[contains(@class,'outcome')]"), "PASS");
  EXPECT_EQ(page.text(row("bias_y") + "/td[contains(@class,'outcome')]"), "INDETERMINATE");
  // Margin = limit - |value| - U: bias_x was given 5 µg of room beyond U.
  EXPECT_NEAR(number_in(page.text(row("bias_x") + "/td[contains(@class,'margin')]")), 5.0, 0.006);
  EXPECT_LT(number_in(page.text(row("bias_z") + "/td[contains(@class,'margin')]")), 0);

  EXPECT_EQ(page.text("//*[@id='verdict']/@data-outcome"), "fail");
  const std::string rule = page.text("//p[@id='rule']");
  EXPECT_NE(rule.find("ILAC-G8"), std::string::npos);
  EXPECT_NE(rule.find("k = 2"), std::string::npos);
  EXPECT_NE(rule.find("PASSES when |value| + U is at most the limit"), std::string::npos);
  EXPECT_NE(rule.find("INDETERMINATE"), std::string::npos);
}

TEST_F(CertificateOfSimulatedRun, DrawsResidualPlotsPerPositionAndAxis) {
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(request())));
  EXPECT_EQ(page.count("//figure[@id='residuals-invariant']//svg"), 1u);
  EXPECT_EQ(page.count("//figure[@id='residuals-axes']//svg"), 1u);
  const std::string axes = page.text("//figure[@id='residuals-axes']//svg");
  for (const char* axis : {"x accelerometer", "y accelerometer", "z accelerometer"})
    EXPECT_NE(axes.find(axis), std::string::npos) << axis << " panel title in the SVG";
  EXPECT_EQ(page.count("//table[@id='compensation']//tr"), 5u) << "header, b and three rows of M";
  // Issue 20: both inline SVGs defined text-clipping0.., and the second lost its text.
  const std::vector<std::string> ids = page.texts("//@id");
  EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()).size(), ids.size()) << "duplicate ids";
}

TEST_F(CertificateOfSimulatedRun, ReportsTheStoredDiagnosisWhenOneWasRun) {
  {
    const HtmlDocument page(
        report::render_certificate_html(report::prepare_certificate(request())));
    EXPECT_EQ(page.text("//*[@id='diagnosis']/@data-verdict"), "not_run");
  }
  write_text(run_dir_ / "diagnosis.json", json{{"verdict", "explained"},
                                               {"summary", {"bias_drift on z: +12.0 ug/h"}},
                                               {"located", json::array()}}
                                              .dump());
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(request())));
  EXPECT_EQ(page.text("//*[@id='diagnosis']/@data-verdict"), "explained");
  EXPECT_NE(page.text("//*[@id='diagnosis']").find("bias_drift on z"), std::string::npos);
}

TEST_F(CertificateOfSimulatedRun, RunsTheDiagnosisOnRequest) {
  CertificateRequest r = request();
  r.diagnose = true;
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(r)));
  // paper9 has no redundant positions, which the diagnosis must say rather than guess.
  EXPECT_EQ(page.text("//*[@id='diagnosis']/@data-verdict"), "insufficient_redundancy");
}

TEST_F(CertificateOfSimulatedRun, ImportedRecordingNamesWhatIsNotRecorded) {
  CertificateRequest r;
  r.recording_path = (run_dir_ / "recording.csv").string();
  const report::CertificateInput in = report::prepare_certificate(r);
  EXPECT_EQ(in.trace.unit_serial, "AU-0042");
  EXPECT_EQ(in.trace.stand_id, "stand-B2") << "from the recording header";
  const HtmlDocument page(report::render_certificate_html(in));
  EXPECT_EQ(page.text("//dl[@id='traceability']/dd[@data-field='operator']"), "(not recorded)");
  EXPECT_NE(page.text("//ul[@id='remarks']").find("the operator is not recorded"),
            std::string::npos);
}

// A recording whose steps give no sample period has no Allan curve, so its means' errors
// make no allowance for samples correlated within a dwell: `fit` says so, and the
// certificate's remarks did not.
TEST_F(CertificateOfSimulatedRun, SaysWhenTheDwellsHaveNoAllanCurve) {
  Recording no_period = rec_;
  no_period.sample_rate_hz = kNoValue;
  std::erase_if(no_period.header, [](const auto& kv) { return kv.first == "sample_rate_hz"; });
  for (RecordingSample& s : no_period.samples) s.t_s = 5;  // repeated time stamps
  CertificateRequest r;
  r.recording_path = state_.file("no-period.csv");
  write_recording(no_period, r.recording_path);
  const report::CertificateInput in = report::prepare_certificate(r);
  const HtmlDocument page(report::render_certificate_html(in));
  EXPECT_NE(page.text("//ul[@id='remarks']").find("the median time step is zero"),
            std::string::npos);
  EXPECT_NE(page.text("//ul[@id='remarks']").find("the dwells have no Allan curve"),
            std::string::npos);
}

// The certificate weighs its fits with the unit's wander the run was made with (standcald's
// unit.bias_instability_*, which the recording's header keeps), as the run's own result did,
// and says what its uncertainties rest on. It had refitted with nothing of the unit's given:
// a nine-position run then came out white, its biases' sigmas several times smaller than the
// run's result gave (this test failed so before the fix).
TEST_F(CertificateOfSimulatedRun, WeighsWithTheUnitsWanderItsRunWasMadeWith) {
  GivenWander wander;
  wander.size_ug = 5;
  wander.known_tau = KnownTau{600, 600};
  Recording made_with = rec_;
  set_unit_wander_header(made_with, wander);
  CertificateRequest r;
  r.recording_path = state_.file("made-with-wander.csv");
  write_recording(made_with, r.recording_path);
  const report::CertificateInput in = report::prepare_certificate(r);
  EXPECT_EQ(in.fit.noise.model, "gauss_markov") << in.fit.noise.how;
  EXPECT_EQ(in.fit.noise.unit_wander_from, kWanderFromHeader) << in.fit.noise.how;
  FitNoiseOptions given;
  wander.give_to(given);
  const FitResult as_the_run = fit_invariant_joint(average_positions(rec_), given);
  const FitResult white = fit_invariant_joint(average_positions(rec_), white_noise_weighting());
  for (int p : {kBiasX, kBiasY, kBiasZ}) {
    const double sigma = *in.fit.unit[static_cast<std::size_t>(p)].sigma;
    EXPECT_NEAR(sigma, *as_the_run.unit[static_cast<std::size_t>(p)].sigma, 1e-9 * sigma) << p;
    EXPECT_GT(sigma, 1.5 * *white.unit[static_cast<std::size_t>(p)].sigma) << p;
  }
  const HtmlDocument page(report::render_certificate_html(in));
  EXPECT_NE(page.text("//p[@id='noise-model']").find("its run was made with"), std::string::npos)
      << page.text("//p[@id='noise-model']");
  // The operator's weighting wins over the header's (`--noise white`).
  r.noise = white_noise_weighting();
  const report::CertificateInput told_white = report::prepare_certificate(r);
  EXPECT_EQ(told_white.fit.noise.model, "white");
  const double sigma_x = *told_white.fit.unit[static_cast<std::size_t>(kBiasX)].sigma;
  EXPECT_NEAR(sigma_x, *white.unit[static_cast<std::size_t>(kBiasX)].sigma, 1e-9 * sigma_x);
}

// Where the unit's static recording sees a wander it does not pin, --diagnose tests the terms
// under the floor its curves put under the correlation time, as `standcal diagnose
// --unit-static-recording` does (DiagnoseOptions::unit_static_tau_floor_s); nothing tested that
// the certificate passes it on. A 5 ug wander of 1200 s under 3 ug/rtHz of white noise (within
// a navigation-grade class's 6 ug, shown by the run's rows): its two-hour static recording
// (seed 1) puts the floor at 432 s, where the run alone favours 60 s.
TEST_F(CertificateOfSimulatedRun, ItsDiagnosisTakesTheFloorTheUnitsStaticRecordingPuts) {
  constexpr double kDensity_ug_rthz = 3, kWander_ug = 5, kTau_s = 1200;
  const auto still = std::make_shared<const RawInput>(
      raw_input_of(unit_static_recording(7200, kWander_ug, kTau_s, 1, kDensity_ug_rthz)));
  const double floor_s =
      stand_unit_static_allan(*still, kStandardGravity_mps2).allan.wander_tau_floor_s;
  ASSERT_GT(floor_s, 60) << "the case this test is of: a floor above the fits' shortest";
  SimulationRequest run;
  run.program = diagnostic32();  // orientations enough for the diagnosis to reach its noise step
  run.truth = default_truth();
  run.truth.noise.density_ug_rthz = kDensity_ug_rthz;
  run.truth.noise.bias_instability_ug = kWander_ug;
  run.truth.noise.bias_instability_tau_s = kTau_s;
  run.timing.dwell_s = 10;
  run.seed = 1;
  run.unit_serial = "AU-0046";
  CertificateRequest r;
  r.recording_path = state_.file("slow-wander.csv");
  write_recording(simulate_run(run), r.recording_path);
  r.unit_static_recording = still;
  r.diagnose = true;
  const report::CertificateInput in = report::prepare_certificate(r);
  ASSERT_TRUE(in.diagnosis.has_value());
  const Recording rec = read_recording(r.recording_path);
  DiagnoseOptions under_floor;
  under_floor.unit_static_tau_floor_s = floor_s;
  const Diagnosis expected = diagnose_recording(rec, under_floor);
  ASSERT_EQ(expected.tau_floor_outcome, "kept");
  EXPECT_GE(expected.noise.tau_s, floor_s);
  const Diagnosis without = diagnose_recording(rec, DiagnoseOptions{});
  ASSERT_LT(without.noise.tau_s, floor_s) << "the case this test is of: the floor tells";
  EXPECT_EQ(in.diagnosis->summary, expected.summary);
}

TEST_F(CertificateOfSimulatedRun, RefusesAnUnfinishedRunOrAMissingOne) {
  write_done_run(state_.path(), "20261122T010000Z-AU-0042", rec_, "faulted");
  CertificateRequest r = request();
  r.run_id = "20261122T010000Z-AU-0042";
  try {
    report::prepare_certificate(r);
    FAIL() << "a faulted run must not be certified";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is 'faulted', not done"), std::string::npos) << e.what();
  }
  r.run_id = "no-such-run";
  EXPECT_THROW(report::prepare_certificate(r), std::runtime_error);
}

// The library itself never follows a run id out of STATE/runs (the CLI checks the form too).
TEST_F(CertificateOfSimulatedRun, ARunIdIsNeverResolvedOutsideTheStateDirectory) {
  const std::filesystem::path other = std::filesystem::path(state_.path()) / "other-state";
  write_done_run(other, "20261122T010000Z-AU-0042", rec_);
  CertificateRequest r = request();
  for (const std::string id : {"../other-state/runs/20261122T010000Z-AU-0042", "..", "."}) {
    r.run_id = id;
    try {
      report::prepare_certificate(r);
      ADD_FAILURE() << id << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("is not a run id"), std::string::npos) << e.what();
    }
  }
}

TEST(CertificateOfClassic24, LimitedParametersTheProgrammeCannotMeasureMakeItIndeterminate) {
  // classic24 with the invariant estimator sees no non-orthogonality (u = ±e_i everywhere).
  TempDir state;
  // One rigid fixture for the three mountings: what the full-vector fit assumes by default.
  TruthModel truth = default_truth();
  truth.stand.mounting_rad[1] = truth.stand.mounting_rad[2] = truth.stand.mounting_rad[0];
  const Recording rec = simulated_recording("AU-0043", truth, 3, "classic24", 2);
  write_done_run(state.path(), "20261121T230000Z-AU-0043", rec);
  write_text(state.file("limits.json"),
             R"({"format": "standcal-limits/1", "unit_types": {"QA-2000": {
      "parameters": {"bias": {"max_abs": 500}, "scale": {"max_abs": 2000}, "gamma": {"max_abs": 60}}}}})");
  CertificateRequest r;
  r.state_dir = state.path();
  r.run_id = "20261121T230000Z-AU-0043";
  r.limits_path = state.file("limits.json");
  const HtmlDocument page(report::render_certificate_html(report::prepare_certificate(r)));
  EXPECT_EQ(page.text(row("scale_z") + "/@data-outcome"), "pass");
  EXPECT_EQ(page.text(row("gamma13") + "/@data-outcome"), "not_evaluated");
  EXPECT_EQ(page.text(row("gamma13") + "/td[contains(@class,'value')]"), "not measured");
  EXPECT_EQ(page.text("//*[@id='verdict']/@data-outcome"), "indeterminate");

  r.method = "full";  // the full-vector fit sees them through the horizontal components
  const HtmlDocument full(report::render_certificate_html(report::prepare_certificate(r)));
  EXPECT_EQ(full.text(row("gamma13") + "/@data-outcome"), "pass");
  EXPECT_EQ(full.text("//*[@id='verdict']/@data-outcome"), "pass");
}

TEST_F(CertificateOfSimulatedRun, EscapesTextFromTheRecords) {
  Recording rec = rec_;
  rec.unit_serial = "AU<script>";
  write_done_run(state_.path(), "20261122T020000Z-AU-X", rec);
  CertificateRequest r = request();
  r.run_id = "20261122T020000Z-AU-X";
  const std::string html = report::render_certificate_html(report::prepare_certificate(r));
  EXPECT_EQ(html.find("<script>"), std::string::npos);
  EXPECT_EQ(HtmlDocument(html).text("//dl[@id='traceability']/dd[@data-field='unit_serial']"),
            "AU<script>");
}

}  // namespace
}  // namespace standcal::test
