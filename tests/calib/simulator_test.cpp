// The simulator: noise as model.md defines it, timing of a run, reproducibility.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "calib/simulator.hpp"

using namespace standcal;

namespace {

Recording simulate(const Program& program, const TruthModel& truth, RunTiming timing = {},
                   std::uint64_t seed = 1) {
  SimulationRequest req;
  req.program = program;
  req.truth = truth;
  req.timing = timing;
  req.seed = seed;
  return simulate_run(req);
}

Program one_position(double a1, double a2) {
  Program p;
  p.name = "one";
  ProgramPosition pos;
  pos.alpha1_deg = a1;
  pos.alpha2_deg = a2;
  p.positions.push_back(pos);
  return p;
}

double axis_sigma_g(const Recording& rec, int axis) {
  double sum = 0, sum_sq = 0;
  for (const auto& s : rec.samples) {
    const double v = s.f_mps2[axis] / rec.g_local_mps2;
    sum += v;
    sum_sq += v * v;
  }
  const double n = static_cast<double>(rec.samples.size());
  return std::sqrt((sum_sq - sum * sum / n) / (n - 1));
}

}  // namespace

TEST(Simulator, SampleSigmaIsNoiseDensityTimesRootSampleRate) {
  TruthModel truth;
  truth.noise.density_ug_rthz = 20;
  RunTiming timing;
  timing.dwell_s = 100;
  timing.sample_rate_hz = 400;
  const Recording rec = simulate(one_position(0, 0), truth, timing);
  ASSERT_EQ(rec.samples.size(), 40000u);
  const double expected = 20e-6 * std::sqrt(400.0);  // 400 ug
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(axis_sigma_g(rec, a), expected, 0.02 * expected);
}

TEST(Simulator, NoiseFreeOutputIsTheFullModel) {
  TruthModel truth = default_truth();
  truth.noise.density_ug_rthz = 0;
  const Recording rec = simulate(one_position(30, 70), truth);
  const Vec3 J = unit_output_g(
      truth.unit, true_up_vector(30 * kDegToRad, 70 * kDegToRad, Mount::x, truth.stand));
  EXPECT_LT((rec.samples[10].f_mps2 / truth.g_local_mps2 - J).norm(), 1e-15);
}

TEST(Simulator, QuantisesToTheLsb) {
  TruthModel truth;
  truth.noise.quantization_ug = 50;
  const Recording rec = simulate(one_position(10, 20), truth);
  const double lsb = 50e-6 * truth.g_local_mps2;
  for (std::size_t i = 0; i < rec.samples.size(); i += 97) {
    const double q = rec.samples[i].f_mps2.x() / lsb;
    EXPECT_NEAR(q, std::round(q), 1e-6);
  }
}

TEST(Simulator, RandomWalkGrowsWithTheSquareRootOfTime) {
  // Mean of an axis over many seeds: the spread of the bias after 1 h is K * sqrt(1 h).
  TruthModel truth;
  truth.noise.density_ug_rthz = 0;
  truth.noise.random_walk_ug_rthr = 30;
  RunTiming timing;
  timing.dwell_s = 3600;
  timing.sample_rate_hz = 1;
  double sum_sq = 0;
  constexpr int kSeeds = 300;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const Recording rec =
        simulate(one_position(0, 0), truth, timing, static_cast<std::uint64_t>(seed));
    const double drift_g =
        (rec.samples.back().f_mps2.x() - rec.samples.front().f_mps2.x()) / truth.g_local_mps2;
    sum_sq += drift_g * drift_g;
  }
  // Over 3599 s the walk spreads 30 ug * sqrt(3599/3600); 300 seeds estimate it to ~4 %.
  EXPECT_NEAR(std::sqrt(sum_sq / kSeeds), 30e-6, 0.15 * 30e-6);
}

TEST(Simulator, TimingFollowsMovesSettleDwellAndRemounts) {
  RunTiming timing;
  timing.dwell_s = 2;
  timing.settle_s = 5;
  timing.move_rate_deg_s = 10;
  timing.remount_s = 600;
  TruthModel truth;
  Program p = one_position(90, 30);  // 9 s move from (0, 0)
  ProgramPosition second;
  second.alpha1_deg = 90;
  second.alpha2_deg = 30;
  second.mount = Mount::y;  // a re-mount, no move
  p.positions.push_back(second);
  const Recording rec = simulate(p, truth, timing);
  EXPECT_DOUBLE_EQ(rec.samples.front().t_arrive_s, 9.0);
  EXPECT_DOUBLE_EQ(rec.samples.front().t_s, 14.0);
  const RecordingSample& first_of_second = rec.samples[200];
  EXPECT_EQ(first_of_second.pos, 1);
  EXPECT_NEAR(first_of_second.t_arrive_s, 14.0 + 1.99 + 600.0, 1e-9);
  EXPECT_EQ(*first_of_second.mount, Mount::y);
  EXPECT_EQ(first_of_second.approach, +1);
}

TEST(Simulator, SameSeedSameRunOtherSeedOtherNoise) {
  const Recording a = simulate(paper9(), default_truth(), {}, 7);
  const Recording b = simulate(paper9(), default_truth(), {}, 7);
  const Recording c = simulate(paper9(), default_truth(), {}, 8);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  EXPECT_EQ(a.samples[1234].f_mps2, b.samples[1234].f_mps2);
  EXPECT_NE(a.samples[1234].f_mps2, c.samples[1234].f_mps2);
}

TEST(Simulator, ModelFileRoundTripsAndRejectsTypos) {
  const TruthModel t = default_truth();
  const TruthModel back = truth_from_json(truth_to_json(t), "t.json");
  EXPECT_LT((back.unit.gamma_rad - t.unit.gamma_rad).norm(), 1e-18);
  EXPECT_LT((back.stand.mounting_rad[2] - t.stand.mounting_rad[2]).norm(), 1e-18);
  auto doc = truth_to_json(t);
  doc["unit"]["bias_ugg"] = {1, 2, 3};
  try {
    truth_from_json(doc, "t.json");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "t.json.unit: unknown key 'bias_ugg'");
  }
  doc = truth_to_json(t);
  doc["unit"]["scale_ppm"] = {1, 2};
  EXPECT_THROW(truth_from_json(doc, "t.json"), std::runtime_error);
}
