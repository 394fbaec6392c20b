// The extra physics in standcal-model/1 and in the simulator (issue 6): round trip,
// rejection of bad entries, and byte-identical JSON for models without extra physics.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "calib/units.hpp"

namespace standcal {
namespace {

// The default unit and stand without noise: what an extra term adds is exactly visible.
TruthModel noise_free_truth() {
  TruthModel t = default_truth();
  t.noise = NoiseModel{};
  t.noise.density_ug_rthz = 0;
  t.temperature.noise_c = 0;
  return t;
}

TEST(ExtraPhysicsJson, ModelsWithoutExtraPhysicsHaveNoKey) {
  EXPECT_FALSE(truth_to_json(default_truth()).contains("extra_physics"));
}

TEST(ExtraPhysicsJson, RoundTrip) {
  TruthModel t = default_truth();
  t.extra_physics.push_back({"scale_nonlinearity_k2", "z", -34, 0});
  t.extra_physics.push_back({"cross_coupling", "zx", 12, 0});
  t.extra_physics.push_back({"settling_transient", "y", 60, 4});
  const nlohmann::json j = truth_to_json(t);
  EXPECT_EQ(j["extra_physics"][0]["unit"], "ug/g2");
  EXPECT_EQ(j["extra_physics"][2]["tau_s"], 4.0);
  const TruthModel back = truth_from_json(j, "model");
  ASSERT_EQ(back.extra_physics.size(), 3u);
  EXPECT_EQ(back.extra_physics[1].axis, "zx");
  EXPECT_DOUBLE_EQ(back.extra_physics[0].value, -34);
  EXPECT_EQ(truth_to_json(back)["extra_physics"], j["extra_physics"]);
}

TEST(ExtraPhysicsJson, RejectsBadEntries) {
  nlohmann::json j = truth_to_json(default_truth());
  j["extra_physics"] = {
      {{"id", "scale_nonlinearity_k2"}, {"axis", "z"}, {"value", 1}, {"colour", "red"}}};
  EXPECT_THROW(truth_from_json(j, "m"), std::runtime_error);
  j["extra_physics"] = {{{"id", "warp_drive"}, {"axis", "z"}, {"value", 1}}};
  EXPECT_THROW(truth_from_json(j, "m"), std::runtime_error);
  j["extra_physics"] = {{{"id", "cross_coupling"}, {"axis", "z"}, {"value", 1}}};
  EXPECT_THROW(truth_from_json(j, "m"), std::runtime_error);
  j["extra_physics"] = {{{"id", "bias_drift"}, {"axis", "x"}, {"value", 1}, {"unit", "ppm"}}};
  EXPECT_THROW(truth_from_json(j, "m"), std::runtime_error);
  j["extra_physics"] = {{{"id", "settling_transient"}, {"axis", "x"}, {"value", 1}}};
  EXPECT_THROW(truth_from_json(j, "m"), std::runtime_error);
}

TEST(ExtraPhysicsJson, AngleSensorErrorRoundTripAndRejections) {
  TruthModel t = default_truth();
  t.extra_physics.push_back({"angle_sensor_error", "alpha2", 6, 0, 45});
  const nlohmann::json j = truth_to_json(t);
  EXPECT_EQ(j["extra_physics"][0]["unit"], "arcsec");
  EXPECT_EQ(j["extra_physics"][0]["phase_deg"], 45.0);
  const TruthModel back = truth_from_json(j, "model");
  ASSERT_EQ(back.extra_physics.size(), 1u);
  EXPECT_EQ(back.extra_physics[0].axis, "alpha2");
  EXPECT_DOUBLE_EQ(back.extra_physics[0].phase_deg, 45);
  nlohmann::json bad = j;
  bad["extra_physics"][0]["axis"] = "z";  // a stand axis, not an accelerometer
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
  bad = j;
  bad["extra_physics"] = {{{"id", "bias_drift"}, {"axis", "x"}, {"value", 1}, {"phase_deg", 3}}};
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
}

TEST(ExtraPhysicsJson, ScaleAsymmetryAndStandLevelDriftRoundTripAndRejections) {
  TruthModel t = default_truth();
  t.extra_physics.push_back({"scale_asymmetry", "y", 25, 0});
  t.extra_physics.push_back({"stand_level_drift", "z", 4, 0});
  const nlohmann::json j = truth_to_json(t);
  EXPECT_EQ(j["extra_physics"][0]["unit"], "ug/g2");
  EXPECT_EQ(j["extra_physics"][1]["unit"], "arcsec/h");
  const TruthModel back = truth_from_json(j, "model");
  ASSERT_EQ(back.extra_physics.size(), 2u);
  EXPECT_EQ(back.extra_physics[1].id, "stand_level_drift");
  EXPECT_EQ(back.extra_physics[1].axis, "z");
  EXPECT_EQ(truth_to_json(back)["extra_physics"], j["extra_physics"]);
  nlohmann::json bad = j;
  bad["extra_physics"][1]["axis"] = "y";  // a rotation about y_S leaves gravity unchanged
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
  bad = j;
  bad["extra_physics"][1]["unit"] = "arcsec";
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
  bad = j;
  bad["extra_physics"][0]["axis"] = "alpha1";
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
}

TEST(TemperatureProfileJson, CycleKeysOnlyWhenThereIsACycle) {
  TruthModel t = default_truth();
  EXPECT_FALSE(truth_to_json(t)["temperature"].contains("cycle_amplitude_c"));
  t.temperature.cycle_amplitude_c = 2;
  t.temperature.cycle_period_s = 600;
  const nlohmann::json j = truth_to_json(t);
  const TruthModel back = truth_from_json(j, "model");
  EXPECT_DOUBLE_EQ(back.temperature.cycle_amplitude_c, 2);
  EXPECT_DOUBLE_EQ(back.temperature.cycle_period_s, 600);
  nlohmann::json bad = j;
  bad["temperature"]["cycle_period_s"] = 0;
  EXPECT_THROW(truth_from_json(bad, "m"), std::runtime_error);
  // The simulated temperature follows ramp + cycle.
  t.temperature.noise_c = 0;
  t.temperature.rate_c_per_h = 3.6;
  UnitSimulator u(t, 1, 100);
  EXPECT_NEAR(u.temperature_c(150.0), 23 + 0.15 + 2.0, 1e-9);
}

// The cyclic angle-sensor error turns the true up vector: at alpha2 = 90 deg (z up) an
// inner-axis error of e arcsec moves gravity e * 4.85 ug from z into y.
TEST(ExtraPhysicsSimulator, AngleSensorErrorTurnsTheUpVector) {
  TruthModel t = default_truth();
  t.unit = UnitErrors{};
  t.stand = StandErrors{};
  t.noise = NoiseModel{};
  t.noise.density_ug_rthz = 0;
  TruthModel e = t;
  e.extra_physics.push_back(
      {"angle_sensor_error", "alpha2", 10, 0, 0});  // 10 * sin(90 deg) at alpha2 = 90
  UnitSimulator plain(t, 1, 100), with(e, 1, 100);
  const Vec3 f0 = plain.specific_force_mps2(1.0, 0, 90, Mount::x) / t.g_local_mps2;
  const Vec3 f1 = with.specific_force_mps2(1.0, 0, 90, Mount::x) / t.g_local_mps2;
  // u = [0, cos a2, sin a2]: d u / d a2 at 90 deg = [0, -1, 0].
  EXPECT_NEAR((f1.y() - f0.y()) / kUg, -10 * kArcsecToRad / kUg, 1e-3);
  EXPECT_NEAR(f1.x(), f0.x(), 1e-12);
}

// The simulator applies each term as model.md parametrises it.
TEST(ExtraPhysicsSimulator, TermsFollowTheCatalogParametrisation) {
  const TruthModel t = noise_free_truth();
  TruthModel k2 = t;
  k2.extra_physics.push_back({"scale_nonlinearity_k2", "z", -34, 0});
  UnitSimulator plain(t, 1, 100), with(k2, 1, 100);
  // alpha1 = 0, alpha2 = 90: z up, J_z ~ 1 g.
  const Vec3 f0 = plain.specific_force_mps2(1.0, 0, 90, Mount::x);
  const Vec3 f1 = with.specific_force_mps2(1.0, 0, 90, Mount::x);
  const double jz = f0.z() / t.g_local_mps2;
  EXPECT_NEAR((f1.z() - f0.z()) / t.g_local_mps2 / kUg, -34 * jz * jz, 1e-6);
  EXPECT_NEAR(f1.x(), f0.x(), 1e-12);

  TruthModel hyst = t;
  hyst.extra_physics.push_back({"hysteresis", "x", 10, 0});
  hyst.extra_physics.push_back({"bias_drift", "y", 36, 0});
  UnitSimulator h(hyst, 1, 100), p2(t, 1, 100);
  h.set_position_context(-1, 0.0);
  const Vec3 g0 = p2.specific_force_mps2(3600.0, 0, 0, Mount::x);
  const Vec3 g1 = h.specific_force_mps2(3600.0, 0, 0, Mount::x);
  EXPECT_NEAR((g1.x() - g0.x()) / t.g_local_mps2 / kUg, -10, 1e-6);
  EXPECT_NEAR((g1.y() - g0.y()) / t.g_local_mps2 / kUg, 36, 1e-6);
}

// IEEE 1293's odd-quadratic term: K_oq a |a| changes sign with the input, unlike K2 a^2.
TEST(ExtraPhysicsSimulator, ScaleAsymmetryIsOddInTheInput) {
  const TruthModel t = noise_free_truth();
  TruthModel oq = t;
  oq.extra_physics.push_back({"scale_asymmetry", "y", 25, 0});
  UnitSimulator plain(t, 1, 100), with(oq, 1, 100);
  for (double alpha1_deg : {0.0, 180.0, 60.0}) {  // y up, y down, y at cos 60 deg
    const Vec3 f0 = plain.specific_force_mps2(1.0, alpha1_deg, 0, Mount::x) / t.g_local_mps2;
    const Vec3 f1 = with.specific_force_mps2(1.0, alpha1_deg, 0, Mount::x) / t.g_local_mps2;
    EXPECT_NEAR((f1.y() - f0.y()) / kUg, 25 * f0.y() * std::abs(f0.y()), 1e-6) << alpha1_deg;
    EXPECT_NEAR(f1.x(), f0.x(), 1e-12);
  }
}

// The stand's base level turns linearly from t = 0: after one hour of 20 arcsec/h about
// z_S the unit reads as on a stand levelled 20 arcsec further about z_S (model.md's C_eps).
TEST(ExtraPhysicsSimulator, StandLevelDriftTurnsTheLevelWithTime) {
  const TruthModel t = noise_free_truth();
  TruthModel drifting = t;
  drifting.extra_physics.push_back({"stand_level_drift", "z", 20, 0});
  TruthModel tilted = t;
  tilted.stand.levelling_z_rad += 20 * kArcsecToRad;
  UnitSimulator d(drifting, 1, 100), at_one_hour(tilted, 1, 100), plain(t, 1, 100);
  EXPECT_EQ(d.specific_force_mps2(0.0, 30, 45, Mount::x),
            plain.specific_force_mps2(0.0, 30, 45, Mount::x));
  const Vec3 f1 = d.specific_force_mps2(3600.0, 30, 45, Mount::x);  // same pose, one hour on
  const Vec3 f2 = at_one_hour.specific_force_mps2(3600.0, 30, 45, Mount::x);
  EXPECT_LT((f1 - f2).norm() / t.g_local_mps2, 1e-12);
  EXPECT_GT((f1 - plain.specific_force_mps2(3600.0, 30, 45, Mount::x)).norm() / t.g_local_mps2,
            50 * kUg);
}

// Without extra physics a simulated run is exactly what it was before the extension.
TEST(ExtraPhysicsSimulator, EmptyExtraPhysicsLeavesTheRunUnchanged) {
  SimulationRequest req;
  req.program = paper9();
  req.truth = default_truth();
  req.timing.dwell_s = 1;
  const Recording a = simulate_run(req);
  req.truth.extra_physics.push_back({"bias_drift", "x", 0.0, 0});
  const Recording b = simulate_run(req);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); ++i)
    ASSERT_EQ(a.samples[i].f_mps2, b.samples[i].f_mps2);
  EXPECT_TRUE(a.header_value("temp_ref_c").empty());
  EXPECT_FALSE(b.header_value("temp_ref_c").empty());
}

}  // namespace
}  // namespace standcal
