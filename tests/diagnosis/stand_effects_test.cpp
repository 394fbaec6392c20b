// Blind tests of the two stand-side candidates of the catalog (angle_sensor_error,
// mounting_misalignment_large) and of proposals that respect the stand's reachable
// angles. Each recording is simulated with the concealed effect; the diagnosis is told
// nothing about it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "tests/diagnosis/blind_support.hpp"

namespace standcal {
namespace {

using blind::print;
using blind::simulate;

// Cyclic (once per revolution) angle-sensor error: the true angle is the reading +
// value * sin(alpha + phase). Sizes are 4-5x the discrimination thresholds that
// bench_diagnosis_harness prints for diagnostic32 (1.8 arcsec alpha1, 2.2 arcsec alpha2).
void expect_angle_error_found(const std::string& stand_axis, double amplitude_arcsec, double phase_deg, std::uint64_t seed) {
  TruthModel t = default_truth();
  t.extra_physics.push_back({"angle_sensor_error", stand_axis, amplitude_arcsec, 0, phase_deg});
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, seed));
  print(d);
  ASSERT_FALSE(d.findings.empty());
  const Finding& f = d.findings.front();
  EXPECT_EQ(f.effect, "angle_sensor_error");
  EXPECT_EQ(f.axis, stand_axis);
  EXPECT_EQ(f.unit, "arcsec");
  EXPECT_LT(std::abs(f.value - amplitude_arcsec), 3 * f.sigma) << f.value << " +- " << f.sigma;
  // The phase, within what the amplitude's sigma allows (sigma_phase ~ sigma / amplitude).
  EXPECT_LT(std::abs(std::remainder(f.phase_deg - phase_deg, 360.0)), 3 * f.sigma / amplitude_arcsec * kRadToDeg + 1);
  EXPECT_EQ(d.verdict, "explained");
  // The augmented model carries it in a form the simulator accepts.
  const TruthModel back = truth_from_json(truth_to_json(d.model), "augmented");
  ASSERT_FALSE(back.extra_physics.empty());
  EXPECT_EQ(back.extra_physics.front().id, "angle_sensor_error");
  EXPECT_NEAR(back.extra_physics.front().phase_deg, f.phase_deg, 1e-9);
}

TEST(DiagnosisBlind, AngleSensorErrorOnOuterAxis) { expect_angle_error_found("alpha1", 8, 30, 51); }
TEST(DiagnosisBlind, AngleSensorErrorOnInnerAxis) { expect_angle_error_found("alpha2", 9, -120, 52); }

// A unit mounted far from the fixture's nominal: the full-vector fit models it exactly (its
// residuals are noise), but its size is a finding: the invariant method would absorb it
// silently into the scale factors and non-orthogonalities.
void expect_large_mounting_found(int axis, double psi_arcmin, std::uint64_t seed) {
  TruthModel t = default_truth();
  t.stand.mounting_rad[0][axis] = psi_arcmin * kArcminToRad;
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, seed));
  print(d);
  ASSERT_FALSE(d.findings.empty());
  const Finding& f = d.findings.front();
  EXPECT_EQ(f.effect, "mounting_misalignment_large");
  EXPECT_EQ(f.axis, std::string(1, "xyz"[axis]));
  EXPECT_EQ(f.unit, "arcmin");
  // What gravity can see: the mounting composed with the antisymmetric non-orthogonality
  // (and, about the inner axis x, with the inner-axis angle zero).
  const double visible_arcmin = identifiable_mounting_rad(t)[axis] / kArcminToRad;
  EXPECT_LT(std::abs(f.value - visible_arcmin), 3 * f.sigma) << f.value << " +- " << f.sigma << " truth " << visible_arcmin;
  EXPECT_NEAR(f.value, psi_arcmin, 1.0);  // the combination is within an arcminute of psi itself
  EXPECT_NE(f.explanation.find("invariant method"), std::string::npos);
  EXPECT_EQ(d.verdict, "explained");
  EXPECT_EQ(d.findings.size(), 1u);  // nothing else is mistaken for it
  EXPECT_NEAR(d.model.stand.mounting_rad[0][axis] / kArcminToRad, f.value, 1e-9);
}

TEST(DiagnosisBlind, LargeMountingAboutY) { expect_large_mounting_found(1, 40, 53); }
TEST(DiagnosisBlind, LargeMountingAboutInnerAxisX) { expect_large_mounting_found(0, -25, 54); }

// The default unit's mounting (30-45 arcsec) is within the fixture tolerance: tested, not found.
TEST(DiagnosisBlind, NormalMountingIsTestedButNotAFinding) {
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), default_truth(), 55));
  int tested = 0;
  for (const CandidateTest& c : d.candidates)
    if (c.effect == "mounting_misalignment_large" && c.testable) {
      ++tested;
      EXPECT_LT(std::abs(c.value), 1.0) << c.axis;
      EXPECT_EQ(c.delta_chi2, 0.0);
    }
  EXPECT_EQ(tested, 3);
  EXPECT_EQ(d.verdict, "consistent");
  for (const std::string& s : d.not_tested) EXPECT_EQ(s.find("angle_sensor_error"), std::string::npos) << s;
}

bool inside(double angle_deg, const AxisRange& r) {
  return r.continuous || (angle_deg >= r.min_deg - 1e-9 && angle_deg <= r.max_deg + 1e-9);
}

// Proposed positions lie where the stand can go. Without limits the proposals for paper9
// include poses outside the restricted range, so the restriction is what keeps them in.
TEST(DiagnosisProposals, RespectTheStandLimits) {
  const Recording rec = simulate(paper9(), default_truth(), 56);
  const Diagnosis free = diagnose_recording(rec);
  ASSERT_EQ(free.verdict, "insufficient_redundancy");
  DiagnoseOptions opt;
  opt.limits.alpha1 = {false, -40, 100};
  opt.limits.alpha2 = {false, -10, 120};
  bool free_leaves_range = false;
  for (const ProposedPosition& p : free.proposed_positions)
    free_leaves_range = free_leaves_range || !inside(p.alpha1_deg, opt.limits.alpha1) || !inside(p.alpha2_deg, opt.limits.alpha2);
  EXPECT_TRUE(free_leaves_range);
  const Diagnosis limited = diagnose_recording(rec, opt);
  ASSERT_EQ(limited.verdict, "insufficient_redundancy");
  ASSERT_FALSE(limited.proposed_positions.empty());
  for (const ProposedPosition& p : limited.proposed_positions) {
    std::printf("proposed (%.1f, %.1f): %s\n", p.alpha1_deg, p.alpha2_deg, p.why.c_str());
    EXPECT_TRUE(inside(p.alpha1_deg, opt.limits.alpha1)) << p.alpha1_deg;
    EXPECT_TRUE(inside(p.alpha2_deg, opt.limits.alpha2)) << p.alpha2_deg;
  }
}

// The default +-180 deg range: proposals are normalised into it (no 270 deg, say).
TEST(DiagnosisProposals, DefaultRangeIsPlusMinus180) {
  const Diagnosis d = diagnose_recording(simulate(paper9(), default_truth(), 57));
  ASSERT_FALSE(d.proposed_positions.empty());
  for (const ProposedPosition& p : d.proposed_positions) {
    EXPECT_GE(p.alpha1_deg, -180);
    EXPECT_LE(p.alpha1_deg, 180);
    EXPECT_GE(p.alpha2_deg, -180);
    EXPECT_LE(p.alpha2_deg, 180);
  }
}

// A stand that can reach next to nothing still gets only reachable proposals.
TEST(DiagnosisProposals, NarrowRangeGivesOnlyReachablePoses) {
  DiagnoseOptions opt;
  opt.limits.alpha1 = {false, 0, 20};
  opt.limits.alpha2 = {false, 85, 95};
  const Diagnosis d = diagnose_recording(simulate(paper9(), default_truth(), 58), opt);
  for (const ProposedPosition& p : d.proposed_positions) {
    EXPECT_TRUE(inside(p.alpha1_deg, opt.limits.alpha1)) << p.alpha1_deg;
    EXPECT_TRUE(inside(p.alpha2_deg, opt.limits.alpha2)) << p.alpha2_deg;
  }
}

// The thresholds the harness draws its sizes from: finite for every testable candidate on
// diagnostic32 with a cycling chamber, infinite for bias temperature under a pure ramp
// (collinear with drift, see the ambiguity test).
TEST(DiagnosisThresholds, FiniteOnDiagnostic32InfiniteForTemperatureUnderARamp) {
  TruthModel t = default_truth();
  t.temperature.rate_c_per_h = 10;
  t.temperature.cycle_amplitude_c = 2;
  t.temperature.cycle_period_s = 600;
  const auto cycling = discrimination_thresholds(simulate(diagnostic32(), t, 59));
  int angle = 0, mounting = 0;
  for (const auto& th : cycling) {
    EXPECT_TRUE(std::isfinite(th.threshold)) << th.effect << " " << th.axis;
    EXPECT_GT(th.threshold, 0) << th.effect << " " << th.axis;
    angle += th.effect == "angle_sensor_error" ? 1 : 0;
    mounting += th.effect == "mounting_misalignment_large" ? 1 : 0;
  }
  EXPECT_EQ(angle, 2);
  EXPECT_EQ(mounting, 3);
  t.temperature.cycle_amplitude_c = 0;
  bool drift_limited = false;
  for (const auto& th : discrimination_thresholds(simulate(diagnostic32(), t, 59)))
    if (th.effect == "bias_temperature") drift_limited = drift_limited || th.threshold > 1e3 || !std::isfinite(th.threshold);
  EXPECT_TRUE(drift_limited);
}

}  // namespace
}  // namespace standcal
