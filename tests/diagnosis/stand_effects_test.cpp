// Blind tests of the stand-side candidates of the catalog (angle_sensor_error,
// stand_level_drift, mounting_misalignment_large) and of proposals that respect the stand's
// reachable angles. Each recording is simulated with the concealed effect; the diagnosis is
// told nothing about it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <tuple>
#include <utility>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "tests/diagnosis/blind_support.hpp"

namespace standcal {
namespace {

using blind::print;
using blind::simulate;

// One concealed stand-side effect on diagnostic32: the first finding is it, on its axis,
// within 3 sigma of the truth, and the augmented model carries it in a form the simulator
// accepts.
Diagnosis expect_stand_effect_found(const ExtraEffect& e, const std::string& unit,
                                    std::uint64_t seed) {
  TruthModel t = default_truth();
  t.extra_physics.push_back(e);
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), t, seed));
  print(d);
  if (d.findings.empty()) {
    ADD_FAILURE() << e.id << " " << e.axis << ": nothing found";
    return d;
  }
  const Finding& f = d.findings.front();
  EXPECT_EQ(f.effect, e.id);
  EXPECT_EQ(f.axis, e.axis);
  EXPECT_EQ(f.unit, unit);
  EXPECT_LT(std::abs(f.value - e.value), 3 * f.sigma) << f.value << " +- " << f.sigma;
  EXPECT_NE(f.explanation.find("horizontal components"), std::string::npos);
  EXPECT_EQ(d.verdict, "explained");
  const TruthModel back = truth_from_json(truth_to_json(d.model), "augmented");
  EXPECT_FALSE(back.extra_physics.empty() || back.extra_physics.front().id != e.id);
  return d;
}

// Cyclic (once per revolution) angle-sensor error: the true angle is the reading +
// value * sin(alpha + phase). Sizes are 4-5x the discrimination thresholds that
// bench_diagnosis_harness prints for diagnostic32 (1.8 arcsec alpha1, 2.2 arcsec alpha2).
void expect_angle_error_found(const std::string& stand_axis, double amplitude_arcsec,
                              double phase_deg, std::uint64_t seed) {
  const Diagnosis d = expect_stand_effect_found(
      {"angle_sensor_error", stand_axis, amplitude_arcsec, 0, phase_deg}, "arcsec", seed);
  ASSERT_FALSE(d.findings.empty());
  const Finding& f = d.findings.front();
  // The phase, within what the amplitude's sigma allows (sigma_phase ~ sigma / amplitude).
  EXPECT_LT(std::abs(std::remainder(f.phase_deg - phase_deg, 360.0)),
            3 * f.sigma / amplitude_arcsec * kRadToDeg + 1);
  EXPECT_NEAR(truth_from_json(truth_to_json(d.model), "augmented").extra_physics.front().phase_deg,
              f.phase_deg, 1e-9);
}

TEST(DiagnosisBlind, AngleSensorErrorOnOuterAxis) { expect_angle_error_found("alpha1", 8, 30, 51); }
TEST(DiagnosisBlind, AngleSensorErrorOnInnerAxis) {
  expect_angle_error_found("alpha2", 9, -120, 52);
}

// The stand's base level drifting linearly in time (thermal, foundation): the horizontal
// components show a tilt growing with time. Sizes are 4-5x the discrimination thresholds the
// harness prints for diagnostic32 (9.3 arcsec/h about x, nearest bias_drift z; 6.5 about z).
TEST(DiagnosisBlind, StandLevelDriftAboutX) {
  expect_stand_effect_found({"stand_level_drift", "x", 40, 0}, "arcsec/h", 61);
}
TEST(DiagnosisBlind, StandLevelDriftAboutZ) {
  expect_stand_effect_found({"stand_level_drift", "z", 30, 0}, "arcsec/h", 62);
}

// The columns of stand_level_drift are the level's derivative of model.md's up vector, in
// the conventions of true_up_vector (C_eps = exp(-[eps x]) before C1): a finite difference
// of the exact model agrees, and the invariant projection u^T du/deps is zero.
TEST(DiagnosisCatalog, LevelDerivativeFollowsTheModelConventions) {
  const std::tuple<double, double, Mount> poses[] = {{30.0, 60.0, Mount::x},
                                                     {330.0, 120.0, Mount::x},
                                                     {45.0, 270.0, Mount::y},
                                                     {0.0, 0.0, Mount::z}};
  for (const auto& [a1, a2, mount] : poses) {
    diagnosis::PositionContext p;
    p.alpha1_deg = a1;
    p.alpha2_deg = a2;
    p.mount = mount;
    const Vec3 u = up_vector(a1 * kDegToRad, a2 * kDegToRad, mount);
    for (int level_axis : {0, 2}) {
      const double h = 1e-7;
      StandErrors tilted;
      (level_axis == 0 ? tilted.levelling_x_rad : tilted.levelling_z_rad) = h;
      const Vec3 numeric = (true_up_vector(a1 * kDegToRad, a2 * kDegToRad, mount, tilted) -
                            true_up_vector(a1 * kDegToRad, a2 * kDegToRad, mount, StandErrors{})) /
                           h;
      const Vec3 analytic = diagnosis::level_derivative(p, level_axis);
      EXPECT_LT((numeric - analytic).norm(), 1e-6) << a1 << " " << a2 << " axis " << level_axis;
      EXPECT_NEAR(u.dot(analytic), 0, 1e-12);
      EXPECT_NEAR(analytic.norm(), 1, 1e-12);  // gravity is horizontal to both level axes
    }
  }
}

// Without redundancy for the full-vector fit the diagnosis falls back to the invariant
// projection, which cannot see terms that only turn the measured vector: listed as not
// testable, with why, and never with a number.
TEST(DiagnosisTestability, TermsThatTurnTheUpVectorAreNotTestableInTheInvariantProjection) {
  Program three;
  three.name = "three";
  const std::pair<double, double> poses[] = {{144.0, 90.0}, {90.0, 72.0}, {-90.0, 144.0}};
  for (const auto& [a1, a2] : poses)
    three.positions.push_back({a1, a2, Mount::x, std::nullopt, std::nullopt});
  const Diagnosis d = diagnose_recording(simulate(three, default_truth(), 118, 4));
  ASSERT_EQ(d.method, "joint");
  int unseen = 0;
  for (const CandidateTest& c : d.candidates) {
    if (c.effect != "stand_level_drift" && c.effect != "angle_sensor_error") continue;
    EXPECT_FALSE(c.testable) << c.effect << " " << c.axis;
    EXPECT_NE(c.reason.find("invariant projection cannot see it"), std::string::npos) << c.reason;
    ++unseen;
  }
  EXPECT_EQ(unseen, 4);  // level about x and z, angle sensor of alpha1 and alpha2
}

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
  EXPECT_LT(std::abs(f.value - visible_arcmin), 3 * f.sigma)
      << f.value << " +- " << f.sigma << " truth " << visible_arcmin;
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
  for (const std::string& s : d.not_tested)
    EXPECT_EQ(s.find("angle_sensor_error"), std::string::npos) << s;
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
    free_leaves_range = free_leaves_range || !inside(p.alpha1_deg, opt.limits.alpha1) ||
                        !inside(p.alpha2_deg, opt.limits.alpha2);
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
    if (th.effect == "bias_temperature")
      drift_limited = drift_limited || th.threshold > 1e3 || !std::isfinite(th.threshold);
  EXPECT_TRUE(drift_limited);
}

}  // namespace
}  // namespace standcal
