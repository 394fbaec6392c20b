// The independent effect generator of bench/diagnosis (issue 15): its conventions against
// model.md's sign checks, and its noise-free output against calib's simulator for truths
// both can express. The two codes share no physics, so agreement to 1e-12 g says both
// read model.md the same way.
#include <gtest/gtest.h>

#include <cmath>

#include "bench/diagnosis/effect_generator.hpp"
#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"
#include "tests/calib/test_support.hpp"

namespace standcal::bench {
namespace {

constexpr double kAgreement_g = 1e-12;

Program poses(const std::vector<std::pair<double, double>>& angles_deg) {
  return test::program_of("poses", angles_deg);
}

GeneratorRun short_run(const Program& program, double dwell_s = 1) {
  GeneratorRun run;
  run.program = program;
  run.dwell_s = dwell_s;
  return run;
}

GeneratorTruth quiet(GeneratorTruth t = {}) {
  t.white_noise_ug_rthz = 0;
  t.chamber.sensor_noise_c = 0;
  return t;
}

Vec3 mean_output_g(const Recording& rec, int pos) {
  for (const PositionAverage& p : average_positions(rec))
    if (p.pos == pos) return p.mean_g;
  ADD_FAILURE() << "no position " << pos;
  return Vec3::Zero();
}

TEST(EffectGenerator, ModelMdSignChecks) {
  const Recording rec =
      generate_recording(quiet(), short_run(poses({{0, 0}, {0, 90}, {90, 0}, {45, 90}})), 1);
  const double h = std::sqrt(0.5);
  EXPECT_LT((mean_output_g(rec, 0) - Vec3(0, 1, 0)).norm(), kAgreement_g);  // at rest: [0, +g, 0]
  EXPECT_LT((mean_output_g(rec, 1) - Vec3(0, 0, 1)).norm(), kAgreement_g);  // z reads +g
  EXPECT_LT((mean_output_g(rec, 2) - Vec3(1, 0, 0)).norm(), kAgreement_g);  // x reads +g
  EXPECT_LT((mean_output_g(rec, 3) - Vec3(h, 0, h)).norm(), kAgreement_g);
}

TruthModel simulator_truth(const GeneratorTruth& g) {
  TruthModel t;
  t.g_local_mps2 = g.g_local_mps2;
  t.unit = g.unit;
  t.stand = g.stand;
  t.noise.density_ug_rthz = 0;
  t.temperature.start_c = g.chamber.start_c;
  t.temperature.rate_c_per_h = g.chamber.ramp_c_per_h;
  t.temperature.cycle_amplitude_c = g.chamber.cycle_amplitude_c;
  t.temperature.cycle_period_s = g.chamber.cycle_period_s;
  t.temperature.noise_c = 0;
  for (const ConcealedEffect& e : g.effects)
    t.extra_physics.push_back({e.id, e.axis, e.value, e.tau_s, e.phase_deg});
  return t;
}

// Every sample of the harness run, generator against simulator: timing, angles, approach,
// arrival, temperature and the specific force.
void expect_agreement(const GeneratorTruth& truth) {
  const GeneratorRun run = harness_run();
  SimulationRequest req;
  req.program = run.program;
  req.truth = simulator_truth(truth);
  req.timing.dwell_s = run.dwell_s;
  req.timing.settle_s = run.settle_s;
  const Recording sim = simulate_run(req);
  const Recording gen = generate_recording(truth, run, 7);
  ASSERT_EQ(gen.samples.size(), sim.samples.size());
  double worst_g = 0;
  for (std::size_t i = 0; i < gen.samples.size(); ++i) {
    const RecordingSample &a = gen.samples[i], &b = sim.samples[i];
    ASSERT_EQ(a.pos, b.pos);
    ASSERT_NEAR(a.t_s, b.t_s, 1e-9) << "sample " << i;
    ASSERT_EQ(a.alpha1_cmd_deg, b.alpha1_cmd_deg);
    ASSERT_EQ(a.alpha2_cmd_deg, b.alpha2_cmd_deg);
    ASSERT_EQ(a.alpha1_deg, b.alpha1_deg);
    ASSERT_EQ(a.alpha2_deg, b.alpha2_deg);
    ASSERT_EQ(a.approach, b.approach) << "position " << a.pos;
    ASSERT_NEAR(a.t_arrive_s, b.t_arrive_s, 1e-9);
    ASSERT_NEAR(a.temp_c, b.temp_c, 1e-9);
    worst_g = std::max(worst_g, ((a.f_mps2 - b.f_mps2) / truth.g_local_mps2).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst_g, kAgreement_g);
}

// Unit and stand errors of model.md (angle scale errors too) with the attitude-free terms.
TEST(EffectGenerator, AgreesWithTheSimulatorOnUnitStandAndTimeTerms) {
  GeneratorTruth t = quiet();
  t.unit = default_truth().unit;
  t.stand = default_truth().stand;
  t.stand.alpha1_scale = 30 * kPpm;
  t.stand.alpha2_scale = -20 * kPpm;
  t.effects = {{"bias_temperature", "y", 12},
               {"bias_drift", "x", 150},
               {"hysteresis", "z", 8},
               {"settling_transient", "y", 60, 4}};
  expect_agreement(t);
}

// The attitude terms and the angle-sensor cyclic error. The simulator applies nonlinear terms
// to its whole output, the generator to the input axis's specific force (IEEE 1293): the same
// when the unit has no bias, scale or gamma; and it turns angle scale errors after the cyclic
// error, the generator before: the same without scale errors.
TEST(EffectGenerator, AgreesWithTheSimulatorOnAttitudeAndAngleSensorTerms) {
  GeneratorTruth t = quiet();
  t.stand = default_truth().stand;
  t.effects = {{"scale_nonlinearity_k2", "z", -30},
               {"scale_nonlinearity_k3", "x", 25},
               {"cross_coupling", "zx", 15},
               {"scale_temperature", "y", 5},
               {"angle_sensor_error", "alpha1", 8, 0, 30},
               {"angle_sensor_error", "alpha2", 6, 0, -100}};
  expect_agreement(t);
}

TEST(EffectGenerator, LargeMountingAddsToTheMountingAboutThatAxis) {
  GeneratorTruth with_effect = quiet(), with_mounting = quiet();
  with_effect.stand = with_mounting.stand = default_truth().stand;
  with_effect.effects = {{"mounting_misalignment_large", "y", 12}};
  with_mounting.stand.mounting_rad[0][1] += 12 * kArcminToRad;
  const GeneratorRun run = short_run(poses({{30, 60}, {45, 90}}));
  const Recording a = generate_recording(with_effect, run, 1),
                  b = generate_recording(with_mounting, run, 1);
  for (int pos = 0; pos < 2; ++pos)
    EXPECT_LT((mean_output_g(a, pos) - mean_output_g(b, pos)).norm(), kAgreement_g);
}

// K_oq a|a| is odd in a, unlike K2 a^2: +K at a = +1 g, -K at a = -1 g (no other error).
TEST(EffectGenerator, ScaleAsymmetryIsOddInTheInput) {
  GeneratorTruth t = quiet();
  t.effects = {{"scale_asymmetry", "y", 40}};
  const Recording rec = generate_recording(t, short_run(poses({{0, 0}, {180, 0}, {0, 60}})), 1);
  EXPECT_NEAR(mean_output_g(rec, 0).y(), 1 + 40e-6, kAgreement_g);
  EXPECT_NEAR(mean_output_g(rec, 1).y(), -1 - 40e-6, kAgreement_g);
  EXPECT_NEAR(mean_output_g(rec, 2).y(), 0.5 + 40e-6 * 0.25, kAgreement_g);
}

// The level error drifting from t = 0 is, at each instant, a fixed levelling of that size.
TEST(EffectGenerator, StandLevelDriftIsTheLevellingGrownSinceTheStart) {
  GeneratorTruth drifting = quiet();
  drifting.effects = {{"stand_level_drift", "x", 3600},
                      {"stand_level_drift", "z", -1800}};  // 1 and -0.5 arcsec/s
  const Recording rec = generate_recording(drifting, short_run(poses({{30, 60}})), 1);
  const RecordingSample& last = rec.samples.back();
  GeneratorTruth fixed = quiet();
  fixed.stand.levelling_x_rad = last.t_s * kArcsecToRad;
  fixed.stand.levelling_z_rad = -0.5 * last.t_s * kArcsecToRad;
  const Recording still = generate_recording(fixed, short_run(poses({{30, 60}})), 1);
  EXPECT_LT((last.f_mps2 - still.samples.back().f_mps2).norm() / drifting.g_local_mps2,
            kAgreement_g);
  EXPECT_GT((rec.samples.front().f_mps2 - last.f_mps2).norm() / drifting.g_local_mps2,
            1e-6);  // it did move
}

// At one pose, a twice-per-revolution angle error is a zero offset of A sin(2 alpha + phase).
TEST(EffectGenerator, SecondHarmonicAngleErrorTurnsTheUpVectorByItsValue) {
  GeneratorTruth harmonic = quiet(), offset = quiet();
  harmonic.effects = {{"angle_sensor_harmonic2", "alpha2", 20, 0, 40}};
  offset.stand.alpha2_offset_rad = 20 * std::sin((2 * 60.0 + 40) * kDegToRad) * kArcsecToRad;
  const GeneratorRun run = short_run(poses({{30, 60}}));
  EXPECT_LT((mean_output_g(generate_recording(harmonic, run, 1), 0) -
             mean_output_g(generate_recording(offset, run, 1), 0))
                .norm(),
            kAgreement_g);
}

TEST(EffectGenerator, BiasJumpAndOscillationFollowTime) {
  GeneratorTruth t = quiet();
  t.chamber.ramp_c_per_h = t.chamber.cycle_amplitude_c = 0;
  t.effects = {{"bias_jump", "x", 50, 0, 0, 15.0}, {"bias_oscillation", "z", 20, 0, 90, 40.0}};
  const Recording rec = generate_recording(t, short_run(poses({{0, 0}}), 30), 1);
  for (const RecordingSample& s : rec.samples) {
    const Vec3 J = s.f_mps2 / t.g_local_mps2;
    ASSERT_NEAR(J.x(), s.t_s >= 15.0 ? 50e-6 : 0.0, kAgreement_g) << s.t_s;
    ASSERT_NEAR(J.z(), 20e-6 * std::cos(2 * kPi * s.t_s / 40.0), kAgreement_g) << s.t_s;
  }
}

// The Gauss-Markov bias: steady-state sigma and the correlation exp(-dt / tau) between samples.
TEST(EffectGenerator, BiasInstabilityHasItsSigmaAndCorrelationTime) {
  GeneratorTruth t = quiet();
  t.effects = {{"bias_instability", "y", 5, 2}};
  const Recording rec = generate_recording(t, short_run(poses({{90, 0}}), 4000), 3);  // 2000 tau
  double sum = 0, sum_sq = 0, lag = 0;
  std::vector<double> b;
  for (const RecordingSample& s : rec.samples) b.push_back(s.f_mps2.y() / t.g_local_mps2 / kUg);
  for (std::size_t i = 0; i < b.size(); ++i) {
    sum += b[i];
    sum_sq += b[i] * b[i];
    if (i > 0) lag += b[i] * b[i - 1];
  }
  const double n = static_cast<double>(b.size()), mean = sum / n, var = sum_sq / n - mean * mean;
  EXPECT_NEAR(std::sqrt(var), 5, 0.25);  // 2000 tau: ~3 % scatter
  EXPECT_NEAR((lag / (n - 1) - mean * mean) / var, std::exp(-0.01 / 2),
              2e-3);  // one sample = 0.01 s
}

TEST(EffectGenerator, RefusesWhatItDoesNotModel) {
  GeneratorTruth t = quiet();
  t.effects = {{"scale_nonlinearity_k2", "alpha1", 1}};
  EXPECT_THROW(generate_recording(t, harness_run(), 1), std::invalid_argument);
  t.effects = {{"no_such_effect", "x", 1}};
  EXPECT_THROW(generate_recording(t, harness_run(), 1), std::invalid_argument);
  t.effects = {};
  Program remount = poses({{0, 0}});
  remount.positions[0].mount = Mount::y;
  EXPECT_THROW(generate_recording(t, short_run(remount), 1), std::invalid_argument);
}

}  // namespace
}  // namespace standcal::bench
