// The simulated backend behaves like a stand and a unit: lifecycle, moves, time scale,
// and readings that obey calib's model (a calibration run through it recovers the truth).
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "calib/averaging.hpp"
#include "calib/invariant_estimator.hpp"
#include "drivers/sim/sim_backend.hpp"

using namespace standcal;
using namespace standcal::drivers;

namespace {

constexpr double kFast = 500;  // simulated seconds per real second

SimBackend ready_backend(double time_scale = kFast) {
  SimBackendConfig config;
  config.time_scale = time_scale;
  config.move_rate_deg_s = 20;
  SimBackend b = make_sim_backend(config);
  EXPECT_TRUE(b.stand->configure());
  EXPECT_TRUE(b.stand->activate());
  for (StandAxis axis : {StandAxis::outer, StandAxis::inner}) {
    EXPECT_TRUE(b.stand->enable(axis));
    EXPECT_TRUE(b.stand->home(axis));
    EXPECT_TRUE(wait_homed(*b.stand, axis, 10.0));
  }
  EXPECT_TRUE(b.unit->start());
  return b;
}

Result<double> move(Stand& stand, StandAxis axis, double angle_deg) {
  if (Status s = stand.move_to(axis, angle_deg); !s) return s;
  InPositionRule rule;
  rule.dwell_s = 0.01;
  rule.timeout_s = 20;
  rule.poll_s = 0.002;
  const Result<double> target = path_target_deg(stand.range(axis), angle_deg, 0);
  return wait_in_position(stand, axis, normalise_reading_deg(stand.range(axis), target.value()),
                          rule);
}

}  // namespace

TEST(SimStand, RefusesMotionUntilActiveEnabledAndHomed) {
  SimBackendConfig config;
  SimBackend b = make_sim_backend(config);
  EXPECT_EQ(b.stand->move_to(StandAxis::outer, 10).kind, ErrorKind::not_allowed);
  ASSERT_TRUE(b.stand->configure());
  EXPECT_EQ(b.stand->lifecycle(), Lifecycle::inactive);
  EXPECT_EQ(b.stand->move_to(StandAxis::outer, 10).kind, ErrorKind::not_allowed);
  ASSERT_TRUE(b.stand->activate());
  EXPECT_EQ(b.stand->move_to(StandAxis::outer, 10).kind, ErrorKind::not_allowed);  // disabled
  ASSERT_TRUE(b.stand->enable(StandAxis::outer));
  const Status not_homed = b.stand->move_to(StandAxis::outer, 10);
  EXPECT_EQ(not_homed.kind, ErrorKind::not_allowed);
  EXPECT_NE(not_homed.message.find("not homed"), std::string::npos);
}

TEST(SimStand, MovesIntoPositionAndNormalisesToTheRange) {
  SimBackend b = ready_backend();
  const Result<double> reached = move(*b.stand, StandAxis::inner, 270);
  ASSERT_TRUE(reached) << reached.status().message;
  EXPECT_NEAR(reached.value(), -90.0, 1e-9);  // a +-180 deg axis takes 270 as -90
  EXPECT_EQ(b.stand->read_state(StandAxis::inner).value().mode, AxisMode::in_position);
}

TEST(SimStand, EmergencyStopLatchesUntilRecovered) {
  SimBackend b = ready_backend();
  ASSERT_TRUE(b.stand->move_to(StandAxis::outer, 170));
  ASSERT_TRUE(b.stand->emergency_stop());
  EXPECT_EQ(b.stand->lifecycle(), Lifecycle::error);
  const AxisState s = b.stand->read_state(StandAxis::outer).value();
  EXPECT_TRUE(s.estop);
  EXPECT_FALSE(s.enabled);
  EXPECT_EQ(b.stand->move_to(StandAxis::outer, 10).kind, ErrorKind::estop);
  ASSERT_TRUE(b.stand->recover());
  EXPECT_EQ(b.stand->lifecycle(), Lifecycle::inactive);
}

TEST(SimUnit, CollectsAtTheSampleRateInScaledTime) {
  SimBackend b = ready_backend();
  const auto samples = b.unit->collect(30.0);  // 0.06 s of real time at 500x
  ASSERT_TRUE(samples);
  EXPECT_NEAR(static_cast<double>(samples.value().size()), 3000.0, 1.0);
  EXPECT_NEAR(samples.value()[1].t_s - samples.value()[0].t_s, 0.01, 1e-9);
}

// collect_more continues the previous collect's series on the sample grid however long the
// caller takes in between, each window from where the last ended; a plain collect begins at
// its call. At 500x a pause of 20 ms is 10 s of the unit's time, which restarting the grid at
// each call lost from a dwell's chunks, and which a window begun at the call added to the
// series' span (a dwell timed by its caller then came out short or long by the caller's lag).
TEST(SimUnit, CollectMoreContinuesTheSampleGrid) {
  SimBackend b = ready_backend();
  const auto first = b.unit->collect(1.0);
  ASSERT_TRUE(first);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the caller is busy
  const auto next = b.unit->collect_more(1.0);
  ASSERT_TRUE(next);
  ASSERT_FALSE(next.value().empty());
  EXPECT_NEAR(next.value().front().t_s - first.value().back().t_s, 0.01, 1e-9);
  EXPECT_EQ(next.value().front().counter, first.value().back().counter + 1);
  EXPECT_EQ(next.value().size(), 100u);  // the series' second second, not the 10 s since
  const auto then = b.unit->collect_more(1.0);
  ASSERT_TRUE(then);
  ASSERT_EQ(then.value().size(), 100u);
  EXPECT_EQ(then.value().front().counter, next.value().back().counter + 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto plain = b.unit->collect(1.0);
  ASSERT_TRUE(plain);
  ASSERT_FALSE(plain.value().empty());
  EXPECT_GT(plain.value().front().t_s - next.value().back().t_s, 5.0);
}

TEST(SimUnit, SilentUnitFailsTheCollectWithAClearError) {
  SimBackend b = ready_backend();
  b.set_unit_silent(true);
  const auto samples = b.unit->collect(1.0);
  ASSERT_FALSE(samples);
  EXPECT_EQ(samples.status().kind, ErrorKind::timeout);
  EXPECT_NE(samples.status().message.find("silent"), std::string::npos);
  EXPECT_TRUE(b.unit->health().silent);
}

TEST(SimBackend, ACalibrationThroughItRecoversTheTruth) {
  SimBackend b = ready_backend();
  const Program program = paper9();
  std::vector<PositionAverage> averages;
  for (std::size_t i = 0; i < program.positions.size(); ++i) {
    const ProgramPosition& p = program.positions[i];
    ASSERT_TRUE(move(*b.stand, StandAxis::outer, p.alpha1_deg));
    ASSERT_TRUE(move(*b.stand, StandAxis::inner, p.alpha2_deg));
    const double a1 = b.stand->read_angle_deg(StandAxis::outer).value();
    const double a2 = b.stand->read_angle_deg(StandAxis::inner).value();
    const auto samples = b.unit->collect(20.0);
    ASSERT_TRUE(samples);
    Recording rec;
    rec.g_local_mps2 = default_truth().g_local_mps2;
    for (const AccelSample& s : samples.value()) {
      RecordingSample r;
      r.t_s = s.t_s;
      r.pos = static_cast<int>(i);
      r.alpha1_cmd_deg = a1;
      r.alpha2_cmd_deg = a2;
      r.f_mps2 = Vec3(s.force_mps2[0], s.force_mps2[1], s.force_mps2[2]);
      rec.samples.push_back(r);
    }
    averages.push_back(average_positions(rec)[0]);
  }
  const FitResult fit = fit_invariant_joint(averages);
  const UnitErrors& truth = default_truth().unit;
  Eigen::Matrix<double, 9, 1> x;
  x << truth.bias_g, truth.scale, truth.gamma_pair_sums_rad();
  for (std::size_t j = 0; j < 9; ++j)
    EXPECT_NEAR(*fit.unit[j].value, x[static_cast<Eigen::Index>(j)], 5 * *fit.unit[j].sigma)
        << kUnitParameterNames[j];
}
