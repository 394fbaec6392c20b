// Blind tests of `diagnose_recording`: each recording is simulated with one concealed
// effect of the catalog (or none); the diagnosis is told nothing about it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "tests/diagnosis/blind_support.hpp"

namespace standcal {
namespace {

using blind::print;
using blind::simulate;

TruthModel with_effect(const std::string& id, const std::string& axis, double value,
                       double tau_s = 0) {
  TruthModel t = default_truth();
  t.extra_physics.push_back({id, axis, value, tau_s});
  return t;
}

// Whether one sentence of the summary says both things.
bool says(const Diagnosis& d, const std::string& a, const std::string& b = "") {
  for (const std::string& s : d.summary)
    if (s.find(a) != std::string::npos && s.find(b) != std::string::npos) return true;
  return false;
}

struct Concealed {
  std::string id, axis;
  double value, tau_s;
};

Diagnosis expect_found(const Concealed& c, std::uint64_t seed,
                       const DiagnoseOptions& options = {}) {
  TruthModel t = with_effect(c.id, c.axis, c.value, c.tau_s);
  if (c.id == "bias_temperature" || c.id == "scale_temperature") t.temperature.rate_c_per_h = 20;
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, seed), options);
  print(d);
  if (d.findings.empty()) {
    ADD_FAILURE() << c.id << " " << c.axis << " seed " << seed << ": nothing found";
    return d;
  }
  const Finding& f = d.findings.front();
  EXPECT_EQ(f.effect, c.id);
  EXPECT_EQ(f.axis, c.axis);
  EXPECT_LT(std::abs(f.value - c.value), 3 * f.sigma)
      << f.value << " +- " << f.sigma << " truth " << c.value;
  EXPECT_EQ(d.verdict, "explained");
  return d;
}

TEST(DiagnosisBlind, K2OnZ) { expect_found({"scale_nonlinearity_k2", "z", -34, 0}, 11); }
TEST(DiagnosisBlind, BiasDriftOnX) { expect_found({"bias_drift", "x", 150, 0}, 12); }
// The simulator's temperature is a straight line in time, which makes a bias temperature
// coefficient exactly collinear with a bias drift: the honest answer is `ambiguous`.
TEST(DiagnosisBlind, TemperatureRampIsAmbiguousWithDrift) {
  TruthModel t = with_effect("bias_temperature", "y", 25);
  t.temperature.rate_c_per_h = 20;
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, 13));
  print(d);
  EXPECT_EQ(d.verdict, "ambiguous");
  EXPECT_TRUE(says(d, "bias drift of the y", "bias temperature coefficient of the y"));
  // ... and says why no stand position helps and what would: a temperature that is not a
  // straight line in time.
  EXPECT_TRUE(says(d, "No stand position tells these two apart", "not a straight line in time"));
  EXPECT_TRUE(d.proposed_positions.empty());
  EXPECT_TRUE(d.findings.empty());  // neither is claimed
}

// The same ambiguity from the other side: a real drift during a linear temperature ramp.
TEST(DiagnosisBlind, DriftUnderATemperatureRampIsAmbiguousToo) {
  TruthModel t = with_effect("bias_drift", "z", 150);
  t.temperature.rate_c_per_h = 15;
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, 16));
  print(d);
  EXPECT_EQ(d.verdict, "ambiguous");
  EXPECT_TRUE(says(d, "bias drift of the z", "bias temperature coefficient of the z"));
}

// With a cycling chamber (the simulator's temperature cycle) the two separate again.
TEST(DiagnosisBlind, DriftWithACyclingChamberIsNotAmbiguous) {
  TruthModel t = with_effect("bias_drift", "z", 150);
  t.temperature.rate_c_per_h = 15;
  t.temperature.cycle_amplitude_c = 2;
  t.temperature.cycle_period_s = 600;
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, 16));
  print(d);
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings.front().effect, "bias_drift");
  EXPECT_EQ(d.findings.front().axis, "z");
  EXPECT_LT(std::abs(d.findings.front().value - 150), 3 * d.findings.front().sigma);
  EXPECT_EQ(d.verdict, "explained");
}

// A recording from a climatic chamber cycling the temperature (not a straight line in
// time): the recording is simulated without the effect, then the chamber's temperature
// and the unit's response to it are written into it, as a foreign bench would record it.
TEST(DiagnosisBlind, BiasTemperatureOnYWithCyclingChamber) {
  const double coeff_ug_per_c = 25;
  Recording rec = simulate(diagnostic32(), default_truth(), 13);
  rec.temp_ref_c = 23.0;
  for (RecordingSample& s : rec.samples) {
    const double temp_c = 23.0 + 2.0 * std::sin(2 * kPi * s.t_s / 500.0);
    s.temp_c = temp_c;
    s.f_mps2.y() += coeff_ug_per_c * kUg * (temp_c - 23.0) * rec.g_local_mps2;
  }
  const Diagnosis d = diagnose_recording(rec);
  print(d);
  ASSERT_FALSE(d.findings.empty());
  EXPECT_EQ(d.findings.front().effect, "bias_temperature");
  EXPECT_EQ(d.findings.front().axis, "y");
  EXPECT_LT(std::abs(d.findings.front().value - coeff_ug_per_c), 3 * d.findings.front().sigma);
  EXPECT_EQ(d.verdict, "explained");
}
TEST(DiagnosisBlind, HysteresisOnZ) { expect_found({"hysteresis", "z", 12, 0}, 14); }
TEST(DiagnosisBlind, SettlingTransientOnY) { expect_found({"settling_transient", "y", 60, 4}, 15); }

// IEEE 1293's odd-quadratic term K_oq a|a|: found as itself, never as K2 or K3. On
// diagnostic32 K_oq and K3 are nearly collinear (its |u| values 0.5, 0.71, 0.87, 1 leave one
// degree of freedom among u, u|u| and u^3): the size is 4x the discrimination threshold the
// harness prints for y (142 ug/g2, nearest competitor K3 y).
// 600 ug/g2 is far beyond a navigation-grade unit's (the diagnosis would call it
// implausible, ImplausibleValueIsNotExplained): the plausibility bound is lifted here to
// show that the catalog term itself is told from K2 and K3.
TEST(DiagnosisBlind, ScaleAsymmetryOnYIsNotMistakenForANonlinearity) {
  DiagnoseOptions lifted;
  lifted.implausible_factor = 1e3;
  const Diagnosis d = expect_found({"scale_asymmetry", "y", 600, 0}, 60, lifted);
  for (const Finding& f : d.findings) {
    EXPECT_NE(f.effect, "scale_nonlinearity_k3");
    EXPECT_NE(f.effect, "scale_nonlinearity_k2");
  }
}

// The same recording with the plausibility bound: found, but not believed.
TEST(DiagnosisBlind, ImplausibleValueIsNotExplained) {
  const Diagnosis d =
      diagnose_recording(simulate(diagnostic32(), with_effect("scale_asymmetry", "y", 600), 60));
  print(d);
  EXPECT_EQ(d.verdict, "unexplained");
  ASSERT_TRUE(d.checks.made);
  EXPECT_FALSE(d.checks.passed);
  ASSERT_EQ(d.checks.implausible.size(), 1u);
  EXPECT_NE(d.checks.implausible[0].find("scale_asymmetry y"), std::string::npos);
  bool said = false;
  for (const std::string& s : d.summary)
    said = said || s.find("Not explained:") != std::string::npos;
  EXPECT_TRUE(said);
}

// At a plausible size (20 ug/g2, model.md's K2 bound) the same programme cannot tell K_oq
// from K3: the honest answer names both and proposes the poses that separate them best,
// saying that one dwell there is not enough, instead of "explained" by K3 with a wrong value
// (issue 15) or "they differ in time or temperature".
TEST(DiagnosisBlind, ScaleAsymmetryOfPlausibleSizeIsAmbiguousWithK3) {
  const Diagnosis d =
      diagnose_recording(simulate(diagnostic32(), with_effect("scale_asymmetry", "y", 20), 60));
  print(d);
  EXPECT_EQ(d.verdict, "ambiguous");
  EXPECT_TRUE(d.findings.empty());
  EXPECT_TRUE(says(d, "asymmetry K_oq of the y", "K3 of the y"));
  EXPECT_FALSE(d.proposed_positions.empty());
  EXPECT_TRUE(says(d, "repeat them or dwell longer"));
  EXPECT_FALSE(says(d, "differ in time or temperature"));
}

// A run whose temperature stayed within 0.05 degC cannot tell any plausible temperature
// coefficient (model.md: up to 30 ug/degC) from zero: not testable, with why in words and
// no number, in the candidates and in the JSON.
TEST(DiagnosisTestability, TemperatureConstantTo005DegCIsNotTestable) {
  TruthModel t = default_truth();
  t.temperature.rate_c_per_h = 0.25;  // 0.05 degC over the 700 s run
  const Recording rec = simulate(diagnostic32(), t, 70);
  double lo = 1e9, hi = -1e9;
  for (const PositionAverage& p : average_positions(rec)) {
    lo = std::min(lo, p.temp_mean_c);
    hi = std::max(hi, p.temp_mean_c);
  }
  ASSERT_LE(hi - lo, 0.05);
  const Diagnosis d = diagnose_recording(rec);
  print(d);
  int not_testable = 0;
  for (const CandidateTest& c : d.candidates) {
    if (c.effect != "bias_temperature") continue;
    EXPECT_FALSE(c.testable) << c.axis << ": " << c.value << " +- " << c.sigma;
    EXPECT_NE(c.reason.find("temperature"), std::string::npos) << c.reason;
    EXPECT_EQ(c.reason.find_first_of("0123456789"), std::string::npos) << c.reason;
    not_testable += c.testable ? 0 : 1;
  }
  EXPECT_EQ(not_testable, 3);
  // A named json: a range-for over a member of a temporary reads freed memory (ASan).
  const nlohmann::json j = diagnose_to_json(d);
  for (const auto& c : j["candidates"])
    if (c["effect"] == "bias_temperature") {
      EXPECT_FALSE(c.contains("value"));
      EXPECT_FALSE(c.contains("sigma"));
    }
  EXPECT_EQ(d.verdict, "consistent");
}

TEST(DiagnosisBlind, CleanRecordingsAreConsistent) {
  for (std::uint64_t seed : {21, 22, 23, 24}) {
    const Diagnosis d = diagnose_recording(simulate(diagnostic32(), default_truth(), seed));
    print(d);
    EXPECT_EQ(d.verdict, "consistent") << "seed " << seed;
    EXPECT_TRUE(d.findings.empty()) << "seed " << seed;
  }
}

// The unit's correlation time, given (`diagnose --bias-instability-tau-s`, standcald's
// unit.bias_instability_tau_s): the diagnosis estimates the wander's size at it, as the fits
// do, and says so; given as a range, it weighs the times inside it. A 4 ug wander of 600 s
// under 3 ug/rtHz of white noise: with tau estimated over the grid, seed 2's wander came
// out at 7.1 ug, beyond the class's 6 ug, and was refused (`unexplained`, a drift and an
// angle-sensor error "found"), and seed 3's at 60 s left a drift to be "found"
// (`explained`, a false finding); at the given 600 s both
// are `consistent` with a bias-instability finding (failed before: the diagnosis took no
// given tau). Of seeds 1-10, 8 were consistent with tau estimated, 9 with it given.
TEST(DiagnosisBlind, AGivenCorrelationTimeIsTheOneTheWanderIsEstimatedAt) {
  TruthModel t = default_truth();
  t.noise.density_ug_rthz = 3;
  t.noise.bias_instability_ug = 4;
  t.noise.bias_instability_tau_s = 600;
  for (std::uint64_t seed : {2, 3}) {
    const Recording rec = simulate(diagnostic32(), t, seed);
    DiagnoseOptions given;
    given.known_tau = KnownTau{600, 600};
    const Diagnosis d = diagnose_recording(rec, given);
    print(d);
    EXPECT_EQ(d.verdict, "consistent") << seed;
    EXPECT_TRUE(d.findings.empty()) << seed;
    ASSERT_TRUE(d.noise.bias_instability) << seed << ": " << d.noise.how;
    EXPECT_DOUBLE_EQ(d.noise.tau_s, 600);
    EXPECT_TRUE(d.noise.tau_given);
    EXPECT_NE(d.noise.how.find("at the given correlation time 600 s"), std::string::npos)
        << d.noise.how;
    EXPECT_TRUE(says(d, "correlation time 600 s (given; Allan floor")) << seed;
  }
  // A range (what about 100 tau of static recording allows). Seed 2's wander is 6.2 ug at
  // 900 s, the range's likeliest, and is refused by the class bound as it was at 1200 s.
  DiagnoseOptions range;
  range.known_tau = KnownTau{400, 900};
  const Diagnosis r = diagnose_recording(simulate(diagnostic32(), t, 3), range);
  EXPECT_EQ(r.verdict, "consistent");
  ASSERT_TRUE(r.noise.bias_instability) << r.noise.how;
  EXPECT_GE(r.noise.tau_s, 400 * (1 - 1e-9));
  EXPECT_LE(r.noise.tau_s, 900 * (1 + 1e-9));
  EXPECT_DOUBLE_EQ(r.noise.tau_given_min_s, 400);
  EXPECT_DOUBLE_EQ(r.noise.tau_given_max_s, 900);
  EXPECT_NE(r.noise.how.find("at the given correlation times 400-900 s"), std::string::npos)
      << r.noise.how;
  EXPECT_TRUE(says(r, "(within the given 400-900 s; Allan floor"));
}

// The unit's wander given, size and correlation time (`diagnose --bias-instability-ug
// --bias-instability-tau-s`, standcald's unit.bias_instability_*): where the run shows a
// wander that agrees with it, the terms are tested against the given one, as the fits weigh
// with it (noise_model.hpp, run_agrees_with_specified), so that a recording's diagnosis and
// its fit report the same wander. Failed before: the diagnosis tested against the run's own
// (3.5 ug on every axis here, source "estimated") while `fit` weighed with the given 4 ug. A given
// size the run departs from (a tenth) gives way to the run's.
TEST(DiagnosisBlind, AGivenWanderTheRunAgreesWithIsWhatTheTermsAreTestedAgainst) {
  TruthModel t = default_truth();
  t.noise.density_ug_rthz = 3;
  t.noise.bias_instability_ug = 4;
  t.noise.bias_instability_tau_s = 600;
  const Recording rec = simulate(diagnostic32(), t, 3);
  const auto diagnose_given = [&](double size_ug) {
    DiagnoseOptions given;
    given.specified_wander = {Vec3::Constant(size_ug * kUg), 600};
    given.known_tau = KnownTau{600, 600};
    return diagnose_recording(rec, given);
  };
  const Diagnosis d = diagnose_given(4);
  print(d);
  EXPECT_EQ(d.verdict, "consistent");
  EXPECT_TRUE(d.findings.empty());
  ASSERT_TRUE(d.noise.bias_instability) << d.noise.how;
  EXPECT_EQ(d.noise.source, "specified") << d.noise.how;
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(d.noise.wander_ug[a], 4) << a;
  EXPECT_DOUBLE_EQ(d.noise.tau_s, 600);
  EXPECT_NE(d.noise.how.find("consistent with the specified bias instability"), std::string::npos)
      << d.noise.how;
  EXPECT_TRUE(says(d,
                   "by as much as the unit's given wander: Gauss-Markov up to 4.0 ug with "
                   "correlation time 600 s (given)"));

  FitNoiseOptions as_fit;
  as_fit.specified = {Vec3::Constant(4 * kUg), 600};
  as_fit.known_tau = KnownTau{600, 600};
  const FitResult fit = fit_full_vector(average_positions(rec), as_fit);
  EXPECT_EQ(fit.noise.source, d.noise.source) << fit.noise.how;
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(fit.noise.wander_ug[a], d.noise.wander_ug[a]) << a;

  const Diagnosis departs = diagnose_given(0.4);
  EXPECT_EQ(departs.noise.source, "estimated") << departs.noise.how;
  EXPECT_NE(departs.noise.how.find("departs from the specified bias instability"),
            std::string::npos)
      << departs.noise.how;
  EXPECT_GT(departs.noise.wander_ug.minCoeff(), 1.2) << departs.noise.how;
}

TEST(DiagnosisBlind, Paper9HasInsufficientRedundancy) {
  const Diagnosis d =
      diagnose_recording(simulate(paper9(), with_effect("scale_nonlinearity_k2", "z", -34), 5));
  print(d);
  EXPECT_EQ(d.verdict, "insufficient_redundancy");
  EXPECT_FALSE(d.proposed_positions.empty());
}

TEST(DiagnosisBlind, K2OnZReportsAbsorptionAndJson) {
  const Diagnosis d = diagnose_recording(
      simulate(diagnostic32(), with_effect("scale_nonlinearity_k2", "z", -34), 31));
  const nlohmann::json j = diagnose_to_json(d);
  EXPECT_EQ(j["verdict"], "explained");
  EXPECT_EQ(j["method"], "full");
  ASSERT_EQ(j["findings"].size(), 1u);
  EXPECT_EQ(j["findings"][0]["effect"], "scale_nonlinearity_k2");
  EXPECT_EQ(j["findings"][0]["axis"], "z");
  EXPECT_EQ(j["findings"][0]["unit"], "ug/g2");
  EXPECT_GT(j["baseline"]["chi2_dof"].get<double>(), 2.0);
  EXPECT_LT(j["final"]["chi2_dof"].get<double>(), 1.6);
  EXPECT_TRUE(j["final"]["parameters"].is_object());
  EXPECT_NE(j["findings"][0]["explanation"].get<std::string>().find("It had been absorbed into"),
            std::string::npos);
  EXPECT_EQ(j["model"]["extra_physics"][0]["id"], "scale_nonlinearity_k2");
}

// delta_J_L per position (stand errors cancel in it to first order): the recording and a
// re-simulation of the augmented model must agree within noise; the baseline model must not.
double projection_chi2_dof(const Recording& a, const Recording& b) {
  const auto pa = average_positions(a), pb = average_positions(b);
  double chi2 = 0;
  for (std::size_t k = 0; k < pa.size(); ++k) {
    const double da = delta_J_L(pa[k].up(), pa[k].mean_g), db = delta_J_L(pb[k].up(), pb[k].mean_g);
    const double s2 = std::pow(invariant_sigma_g(pa[k]), 2) + std::pow(invariant_sigma_g(pb[k]), 2);
    chi2 += (da - db) * (da - db) / s2;
  }
  return chi2 / static_cast<double>(pa.size());
}

// A unit whose output filter correlates its samples over two periods (0.02 s at 100 Hz: sigma
// / sqrt(n) 2.0x too small) and nothing else: the dwell errors are widened for it, and no
// wander or term is found in what is only noise. Before, every one of these eight was given
// a bias wander (baseline chi2/dof 4.1) and two came out not consistent; now seed 8 of the
// eight is `ambiguous` (baseline P = 0.004: the diagnosis's false-finding rate, <= 1 %
// targeted, not the filter's). The model it writes (--model-out) has the white density a
// dwell mean sees, 10 ug/rtHz, not the filtered samples' 4.9 (as before).
TEST(DiagnosisBlind, SamplesCorrelatedByAnOutputFilterAreNoFinding) {
  TruthModel t = default_truth();
  t.noise.output_filter_tau_s = 0.02;
  int consistent = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, seed));
    if (d.verdict != "consistent") print(d);
    consistent += d.verdict == "consistent";
    EXPECT_TRUE(d.findings.empty()) << "seed " << seed;
    EXPECT_FALSE(d.noise.bias_instability) << "seed " << seed;
    EXPECT_NEAR(d.model.noise.density_ug_rthz, t.noise.density_ug_rthz, 1.5) << "seed " << seed;
  }
  EXPECT_GE(consistent, 7);
}

TEST(DiagnosisBlind, AugmentedModelReproducesTheRecording) {
  const Recording rec =
      simulate(diagnostic32(), with_effect("scale_nonlinearity_k2", "z", -34), 41);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_EQ(d.verdict, "explained");
  TruthModel augmented = truth_from_json(truth_to_json(d.model), "augmented");
  TruthModel without = augmented;
  without.extra_physics.clear();
  const double with_chi2 = projection_chi2_dof(rec, simulate(diagnostic32(), augmented, 42));
  const double without_chi2 = projection_chi2_dof(rec, simulate(diagnostic32(), without, 42));
  std::printf(
      "recording vs re-simulation, delta_J_L chi2/position: augmented %.2f, without the finding "
      "%.2f\n",
      with_chi2, without_chi2);
  EXPECT_LT(with_chi2, 2.0);
  EXPECT_GT(without_chi2, 2 * with_chi2);
}

std::string temp_dir() {
  char tmpl[] = "/tmp/standcal-diag-XXXXXX";
  const char* dir = mkdtemp(tmpl);
  if (!dir) throw std::runtime_error("mkdtemp failed");
  return dir;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(DiagnoseCli, SimulateWithModelThenDiagnoseJsonReportAndModelOut) {
  const std::string dir = temp_dir();
  {
    std::ofstream prog(dir + "/prog.json");
    prog << program_to_json(diagnostic32()).dump();
    TruthModel t = with_effect("bias_drift", "z", 150);
    save_truth(t, dir + "/model.json");
  }
  const std::string cli = STANDCAL_CLI_PATH;
  const std::string sim = cli + " simulate --program " + dir + "/prog.json --model " + dir +
                          "/model.json --seed 7 --dwell-s 10 --settle-s 2 -o " + dir +
                          "/rec.csv 2>/dev/null";
  ASSERT_EQ(std::system(sim.c_str()), 0);
  const std::string diag = cli + " diagnose " + dir + "/rec.csv --json --report " + dir +
                           "/report.html --model-out " + dir + "/aug.json > " + dir +
                           "/out.json 2>/dev/null";
  ASSERT_EQ(std::system(diag.c_str()), 0);
  const nlohmann::json j = nlohmann::json::parse(slurp(dir + "/out.json"));
  EXPECT_EQ(j["verdict"], "explained");
  ASSERT_FALSE(j["findings"].empty());
  EXPECT_EQ(j["findings"][0]["effect"], "bias_drift");
  EXPECT_EQ(j["findings"][0]["axis"], "z");
  EXPECT_NE(slurp(dir + "/report.html").find("bias_drift"), std::string::npos);
  const TruthModel aug = load_truth(dir + "/aug.json");
  ASSERT_EQ(aug.extra_physics.size(), 1u);
  EXPECT_EQ(aug.extra_physics[0].id, "bias_drift");
  // The augmented model is accepted by `standcal simulate --model`.
  const std::string resim = cli + " simulate --program " + dir + "/prog.json --model " + dir +
                            "/aug.json --dwell-s 1 -o " + dir + "/re.csv 2>/dev/null";
  EXPECT_EQ(std::system(resim.c_str()), 0);
  std::filesystem::remove_all(dir);
}

TEST(DiagnoseCli, MissingRecordingFailsWithOneLineReason) {
  const std::string cmd =
      std::string(STANDCAL_CLI_PATH) + " diagnose /nonexistent/rec.csv > /dev/null 2>&1";
  EXPECT_NE(std::system(cmd.c_str()), 0);
}

}  // namespace
}  // namespace standcal
