// The diagnosis of recordings without angles (diagnose_without_angles): stand recordings
// stripped of their angles, with a concealed effect or none, and imu_tk's real Xsens file.
// Inventing physics the data do not support is the worst failure, so the quiet cases
// matter as much as the finding.
#include <gtest/gtest.h>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "tests/diagnosis/blind_support.hpp"

namespace standcal {
namespace {

Diagnosis diagnose_stripped(const TruthModel& truth, std::uint64_t seed) {
  const RawInput in = raw_input_of(blind::simulate(diagnostic32(), truth, seed));
  const Diagnosis d = diagnose_without_angles(in, calibrate_without_angles(in));
  blind::print(d);
  return d;
}

// A K2 makes the interval means disagree with |f| = g in a pattern the all-interval wander
// estimate would absorb; the revisits refuse that wander, and the term is found.
TEST(AttitudeFreeDiagnosis, FindsAScaleNonlinearityWithoutTheAngles) {
  for (double k2 : {20.0, 40.0, 60.0, 100.0}) {
    TruthModel t = default_truth();
    t.extra_physics.push_back({"scale_nonlinearity_k2", "z", k2, 0});
    const Diagnosis d = diagnose_stripped(t, 3);
    EXPECT_EQ(d.method, "norm");
    ASSERT_FALSE(d.findings.empty()) << k2;
    EXPECT_EQ(d.findings.front().effect, "scale_nonlinearity_k2") << k2;
    EXPECT_EQ(d.findings.front().axis, "z") << k2;
    EXPECT_LT(std::abs(d.findings.front().value - k2), 3 * d.findings.front().sigma) << k2;
    EXPECT_EQ(d.verdict, "explained") << k2;
    // Kept only because it is also the same on the even and the odd intervals.
    ASSERT_EQ(d.checks.stability.size(), 1u) << k2;
    EXPECT_EQ(d.checks.stability[0].halves, "alternate");
    EXPECT_TRUE(d.checks.stability[0].stable) << k2;
  }
}

TEST(AttitudeFreeDiagnosis, AUnitWithoutMissingPhysicsIsConsistent) {
  const Diagnosis d = diagnose_stripped(default_truth(), 4);
  EXPECT_EQ(d.verdict, "consistent");
  EXPECT_TRUE(d.findings.empty());
}

// Stand terms have no meaning for a unit placed by hand: never tested, always said why.
TEST(AttitudeFreeDiagnosis, StandTermsAreNotTestedAndSayWhy) {
  const Diagnosis d = diagnose_stripped(default_truth(), 5);
  int stand_terms = 0;
  for (const CandidateTest& c : d.candidates)
    if (c.effect == "angle_sensor_error" || c.effect == "stand_level_drift" ||
        c.effect == "hysteresis") {
      ++stand_terms;
      EXPECT_FALSE(c.testable);
      EXPECT_NE(c.reason.find("no stand"), std::string::npos) << c.reason;
    }
  EXPECT_EQ(stand_terms, 7);
}

// Bias wander only, 1.6 times the white error of a dwell mean: noise that is not white is
// a noise finding, not physics.
TEST(AttitudeFreeDiagnosis, WanderAloneIsConsistentWithABiasInstabilityFinding) {
  TruthModel t = default_truth();
  t.noise.bias_instability_ug = 5;
  t.noise.bias_instability_tau_s = 300;
  const Diagnosis d = diagnose_stripped(t, 6);
  EXPECT_EQ(d.verdict, "consistent");
  EXPECT_TRUE(d.findings.empty());
}

// imu_tk's hand-held Xsens MTi: real noise, not white, and no deterministic term the data
// support.
TEST(AttitudeFreeDiagnosis, TheRealXsensRecordingIsNoiseThatIsNotWhite) {
  InputOptions o;
  o.g_mps2 = 9.81744;
  const RawInput in =
      read_input(std::string(STANDCAL_TEST_DATA) + "/imu_tk_xsens/xsens_acc.mat", o);
  const Diagnosis d = diagnose_without_angles(in, calibrate_without_angles(in));
  blind::print(d);
  EXPECT_EQ(d.verdict, "consistent");
  EXPECT_TRUE(d.findings.empty());
  EXPECT_TRUE(d.noise.bias_instability);
  EXPECT_EQ(d.noise.source, "estimated");
  EXPECT_GT(d.noise.understated_by.minCoeff(), 2.0);
  ASSERT_TRUE(d.noise.allan.has_value());
  // The K2, K3, cross-coupling and drift candidates are tested, not waved through.
  int tested = 0;
  for (const CandidateTest& c : d.candidates) tested += c.testable ? 1 : 0;
  EXPECT_GE(tested, 15);
}

}  // namespace
}  // namespace standcal
