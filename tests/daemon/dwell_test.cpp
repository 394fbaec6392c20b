// The dwell's average and stability rule (daemon/standcald/dwell.hpp), without a daemon.
#include "daemon/standcald/dwell.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "tests/support/statistical.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::daemon {
namespace {

constexpr double kG = 9.80665;
constexpr double kUgMps2 = kG * 1e-6;

// `n` samples at `rate_hz`: x alternates ±sigma_x (so its sample σ is known exactly),
// y rises linearly by `rise_y` over the dwell, z is constant 1 g; temperature 25 °C.
std::vector<drivers::AccelSample> dwell_samples(int n, double rate_hz, double sigma_x,
                                                double rise_y) {
  std::vector<drivers::AccelSample> s;
  const double span_s = (n - 1) / rate_hz;
  for (int i = 0; i < n; ++i) {
    drivers::AccelSample x;
    x.t_s = 1000 + i / rate_hz;
    x.force_mps2 = {0.01 + (i % 2 == 0 ? sigma_x : -sigma_x), 0.2 + rise_y * (i / rate_hz) / span_s,
                    kG};
    x.temperature_c = 25;
    s.push_back(x);
  }
  return s;
}

DwellExpectation expect(double dwell_s, double rate_hz, std::uint64_t incomplete = 0) {
  return DwellExpectation{"sim", dwell_s, rate_hz, incomplete, kG};
}

TEST(DwellAverage, MeanSigmaAndTrendPerAxis) {
  const int n = 1000;
  const auto d = average_dwell(dwell_samples(n, 100, 1e-3, 5e-4));
  EXPECT_EQ(d.count, 1000u);
  EXPECT_NEAR(d.mean_mps2[0], 0.01, 1e-12);
  EXPECT_NEAR(d.mean_mps2[1], 0.2 + 2.5e-4, 1e-12);  // the middle of the ramp
  EXPECT_NEAR(d.mean_mps2[2], kG, 1e-12);
  // ±s alternating: sample variance n s² / (n - 1).
  EXPECT_NEAR(d.sigma_mps2[0], 1e-3 * std::sqrt(n / (n - 1.0)), 1e-12);
  EXPECT_NEAR(d.trend_mps2[1], 5e-4, 1e-12);  // the whole rise over the dwell
  EXPECT_NEAR(d.trend_mps2[2], 0, 1e-12);
  EXPECT_DOUBLE_EQ(d.temp_mean_c, 25);
}

TEST(DwellAverage, NoSamplesAndNoTemperatureAreSaidSo) {
  const auto empty = average_dwell({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_TRUE(std::isnan(empty.temp_mean_c));
  auto s = dwell_samples(10, 100, 0, 0);
  for (auto& x : s) x.temperature_c = std::nan("");
  const auto d = average_dwell(s);
  EXPECT_TRUE(std::isnan(d.temp_mean_c));
  EXPECT_EQ(d.sigma_mps2[2], 0);
}

TEST(DwellStability, AQuietCompleteDwellIsKept) {
  const StabilityRule rule;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 100 * kUgMps2, 0)),
                          expect(10, 100), rule),
            "");
}

TEST(DwellStability, EachReasonIsNamedInTheOperatorsWords) {
  StabilityRule rule;
  // Nothing at all, and no incomplete frame either: the unit said nothing.
  EXPECT_EQ(dwell_problem(average_dwell({}), expect(2.5, 100), rule),
            "no sample from the accelerometer unit sim during the 2.5 s dwell (is it powered and "
            "on the bus?)");
  // 800 of 1000 with the default 90 %.
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(800, 100, 0, 0)), expect(10, 100, 7), rule),
            "only 800 of 1000 expected samples (7 incomplete)");
  // x noisier than the limit (σ = 6000 µg √(1000/999) against 5000 µg).
  const std::string noisy = dwell_problem(
      average_dwell(dwell_samples(1000, 100, 6000 * kUgMps2, 0)), expect(10, 100), rule);
  ASSERT_EQ(noisy.rfind("axis x noise ", 0), 0u) << noisy;
  // Said to six significant digits (calib's number_text): 6003 µg.
  EXPECT_NEAR(std::stod(noisy.substr(13)), 6000 * std::sqrt(1000 / 999.0), 0.5) << noisy;
  EXPECT_NE(noisy.find("µg above the limit 5000 µg"), std::string::npos) << noisy;
  // Just past the limit it reads as past it: six digits said "6003 µg above the limit 6003 µg".
  const DwellAverage noisy_dwell = average_dwell(dwell_samples(1000, 100, 6000 * kUgMps2, 0));
  StabilityRule close = rule;
  close.sigma_limit_ug =
      noisy_dwell.sigma_mps2[0] * 1e6 / expect(10, 100).g_local_mps2 * (1 - 1e-7);
  const std::string just_past = dwell_problem(noisy_dwell, expect(10, 100), close);
  const std::size_t limit_at = just_past.find(" µg above the limit ");
  ASSERT_NE(limit_at, std::string::npos) << just_past;
  const double said_ug = std::stod(just_past.substr(13, limit_at - 13));
  const double said_limit_ug = std::stod(just_past.substr(limit_at + 21));
  EXPECT_GT(said_ug, said_limit_ug) << just_past;
  // y drifted 2500 µg over the dwell against 2000 µg.
  const std::string drift = dwell_problem(
      average_dwell(dwell_samples(1000, 100, 0, 2500 * kUgMps2)), expect(10, 100), rule);
  ASSERT_EQ(drift.rfind("axis y drifted ", 0), 0u) << drift;
  EXPECT_NEAR(std::stod(drift.substr(15)), 2500, 1e-3) << drift;
  EXPECT_NE(drift.find("µg during the dwell (limit 2000 µg)"), std::string::npos) << drift;
  // The limits are the rule's.
  rule.trend_limit_ug = 3000;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 0, 2500 * kUgMps2)),
                          expect(10, 100), rule),
            "");
}

// A wrong CAN layout (a 64-bit field at scale 1) reads a steady 1e13 m/s^2: quiet, so the
// noise limit keeps it, and the recording would then hold a value `standcal fit` refuses.
// Each sample is judged, and before the noise: one such sample among sane ones would
// otherwise be named as noise on whichever axis comes first.
TEST(DwellStability, ADwellNoAccelerometerGivesIsNotKept) {
  const StabilityRule rule;
  auto steady = dwell_samples(1000, 100, 0, 0);
  for (auto& x : steady) x.force_mps2[1] = 1e13;
  EXPECT_EQ(dwell_problem(average_dwell(steady), expect(10, 100), rule),
            "axis y read 1e+13 m/s^2, beyond any accelerometer's output: check the unit's CAN "
            "layout (signal lengths, scale and offset)");
  auto one = dwell_samples(1000, 100, 6000 * kUgMps2, 0);  // x too noisy as well
  one[3].force_mps2[2] = -1.7e308;                         // its square overflows the variance
  const std::string problem = dwell_problem(average_dwell(one), expect(10, 100), rule);
  EXPECT_EQ(problem.rfind("axis z read 1.7e+308 m/s^2, beyond", 0), 0u) << problem;
  auto largest = dwell_samples(1000, 100, 0, 0);
  for (auto& x : largest) x.force_mps2[0] = -1e12;
  EXPECT_EQ(implausible_reading(average_dwell(largest)), "");
}

// The same for the temperature signal: a layout whose temperature reads 1e300 degC made a
// recording every reader refuses (their temperature bound), so the dwell is not kept.
TEST(DwellStability, ADwellNoUnitsTemperatureGivesIsNotKept) {
  const StabilityRule rule;
  auto hot = dwell_samples(1000, 100, 0, 0);
  for (auto& x : hot) x.temperature_c = 23;
  hot[10].temperature_c = 1e300;
  EXPECT_EQ(dwell_problem(average_dwell(hot), expect(10, 100), rule),
            "the unit's temperature read 1e+300 degC, which no unit has (-273.15 ... 1000 degC): "
            "check the temperature signal of the unit's CAN layout (length, scale and offset)");
  hot[10].temperature_c = -300;
  EXPECT_NE(implausible_reading(average_dwell(hot)).find("read -300 degC"), std::string::npos);
  hot[10].temperature_c = kNoValue;  // a sample without a temperature is not judged
  EXPECT_EQ(implausible_reading(average_dwell(hot)), "");
  EXPECT_EQ(average_dwell(hot).temp_max_c, 23);
}

// `n` samples at `rate_hz`, each axis white with sigma `white_ug` plus a Gauss-Markov wander
// (`wander_ug`, `tau_s`), started stationary; y also rises by `rise_y_ug` over the dwell.
// With `output_filter_tau_s`, the white noise passes the unit's first-order output filter
// (as calib's simulator has it: unit gain at low frequency, started stationary).
std::vector<drivers::AccelSample> noisy_dwell(int n, double rate_hz, double white_ug,
                                              double wander_ug, double tau_s, double rise_y_ug,
                                              std::mt19937_64& rng,
                                              double output_filter_tau_s = 0) {
  std::normal_distribution<double> gauss(0, 1);
  const double phi = std::exp(-1 / (rate_hz * tau_s));
  const double drive = wander_ug * std::sqrt(1 - phi * phi);
  const double keep =
      output_filter_tau_s > 0 ? std::exp(-1 / (rate_hz * output_filter_tau_s)) : 0.0;
  const double filtered_sigma = white_ug * std::sqrt((1 - keep) / (1 + keep));
  std::array<double, 3> b{wander_ug * gauss(rng), wander_ug * gauss(rng), wander_ug * gauss(rng)};
  std::array<double, 3> w{};  // drawn only with a filter: the unfiltered draws as before
  if (keep > 0)
    for (double& v : w) v = filtered_sigma * gauss(rng);
  std::vector<drivers::AccelSample> s;
  for (int i = 0; i < n; ++i) {
    drivers::AccelSample x;
    x.t_s = 1000 + i / rate_hz;
    for (int a = 0; a < 3; ++a) {
      b[a] = phi * b[a] + drive * gauss(rng);
      w[a] = keep * w[a] + (1 - keep) * white_ug * gauss(rng);
      x.force_mps2[a] = (a == 2 ? kG : 0.0) + (b[a] + w[a]) * kUgMps2;
    }
    x.force_mps2[1] += rise_y_ug * kUgMps2 * i / (n - 1.0);
    s.push_back(x);
  }
  return s;
}

// The trend the noise explains is the scatter of the trends of simulated dwells: 2000
// dwells of 500 samples at 50 Hz (the sd of a sample sd of 2000 is 1.6 %: 5 % holds).
TEST(DwellStability, TheExplainedTrendIsTheScatterOfSimulatedDwellsTrends) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(31);
  for (const double wander_ug : {0.0, 40.0}) {
    constexpr int kDwells = 2000, kSamples = 500;
    constexpr double kRateHz = 50, kWhiteUg = 50, kTauS = 30;
    double sum_sq = 0, gain = 0;
    for (int k = 0; k < kDwells; ++k) {
      const auto d =
          average_dwell(noisy_dwell(kSamples, kRateHz, kWhiteUg, wander_ug, kTauS, 0, rng));
      sum_sq += std::pow(d.trend_mps2[0] / kUgMps2, 2);
      gain = d.trend_gain;
    }
    EXPECT_NEAR(gain, std::sqrt(12.0 * (kSamples - 1) / (kSamples * (kSamples + 1.0))), 1e-9);
    const double span_s = (kSamples - 1) / kRateHz;
    const double predicted =
        std::hypot(kWhiteUg * gain, wander_trend_sigma(span_s, wander_ug, kTauS));
    EXPECT_NEAR(std::sqrt(sum_sq / kDwells) / predicted, 1.0, 0.05) << "wander " << wander_ug;
  }
  // A wander slow against the dwell drifts it as a random walk, 12 q^2 T / (5 tau); a fast
  // one is white noise of density 2 q^2 tau, 24 q^2 tau / T. (A 256-step midpoint rule
  // gave the fast case 1.4 times the variance.)
  EXPECT_NEAR(wander_trend_sigma(10, 40, 3000), std::sqrt(12 * 40.0 * 40.0 * 10 / (5 * 3000)),
              0.01 * std::sqrt(12 * 1600.0 / 1500));
  EXPECT_NEAR(wander_trend_sigma(600, 40, 1), std::sqrt(24 * 1600.0 / 600), 0.01 * 8);
  EXPECT_EQ(wander_trend_sigma(600, 0, 1), 0);
}

// A dwell whose samples carry no noise gives no measure to judge its drift against: the
// rule keeps it (the absolute trend limit still applies).
TEST(DwellStability, ANoiseFreeDwellIsNotJudgedAgainstItsNoise) {
  StabilityRule rule;
  rule.trend_limit_sigmas = 6;
  EXPECT_EQ(dwell_problem(average_dwell(dwell_samples(1000, 100, 0, 100 * kUgMps2)),
                          expect(10, 100), rule),
            "");
}

// With trend_limit_sigmas set, a drift the noise cannot explain is re-measured; the unit's
// configured wander is part of what explains one.
TEST(DwellStability, ADriftBeyondWhatTheNoiseExplainsIsReMeasuredWhenTheRuleAsks) {
  std::mt19937_64 rng(5);
  // 100 ug white over 1000 samples explains about 11 ug of drift; y drifts 100 ug.
  const DwellAverage drifting = average_dwell(noisy_dwell(1000, 100, 100, 0, 300, 100, rng));
  StabilityRule rule;
  EXPECT_EQ(dwell_problem(drifting, expect(10, 100), rule), "") << "off unless asked for";
  rule.trend_limit_sigmas = 6;
  const std::string problem = dwell_problem(drifting, expect(10, 100), rule);
  ASSERT_EQ(problem.rfind("axis y drifted ", 0), 0u) << problem;
  EXPECT_NE(problem.find("times what its noise explains"), std::string::npos) << problem;
  EXPECT_NE(problem.find("limit 6 times"), std::string::npos) << problem;
  // The same dwell from a unit configured with a 100 ug wander of 60 s: explained.
  DwellExpectation wandering = expect(10, 100);
  wandering.bias_wander_ug = {100, 100, 100};
  wandering.bias_wander_tau_s = 60;
  EXPECT_EQ(dwell_problem(drifting, wandering, rule), "");
  // A unit whose y axis wanders 1 ug where x and z wander 100 (each axis's size, as a static
  // recording pins them): y's drift is not explained by the others' wander. Until 2026-12-07
  // the largest axis's size stood for every axis, and it was.
  wandering.bias_wander_ug = {100, 1, 100};
  EXPECT_EQ(dwell_problem(drifting, wandering, rule).rfind("axis y drifted ", 0), 0u);
  // A quiet dwell is kept.
  EXPECT_EQ(dwell_problem(average_dwell(noisy_dwell(1000, 100, 100, 0, 300, 0, rng)),
                          expect(10, 100), rule),
            "");
}

// Pools a dwell in `run` as the sequencer does, with its average; the widening after it.
std::array<double, 3> add_dwell(DwellSampleCorrelation& run,
                                const std::vector<drivers::AccelSample>& samples) {
  return run.add_dwell(samples, average_dwell(samples));
}

// A unit's output filter correlates consecutive samples, and a dwell's drift then scatters
// more than its samples' sigma says: 2.02 times for a filter of two sample periods
// (sqrt((1 + a) / (1 - a)), a = e^-0.5 from one sample to the next), as its mean's error
// does. Widened by the correlation the run's dwells pooled show, the drift the noise explains
// is again the drifts' scatter, and a quiet dwell is re-measured at 3 times about as seldom
// as a white unit's would be (0.8 %: three axes at 0.27 %).
TEST(DwellStability, AUnitsOutputFilterIsPartOfWhatExplainsADrift) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(41);
  constexpr int kSamples = 250, kDwells = 2000;  // diagnostic32's dwells: 10 s at 25 Hz
  constexpr double kRateHz = 25, kFilterS = 0.08, kWhiteUg = 200;
  const auto dwell = [&](double rise_y_ug = 0) {
    return noisy_dwell(kSamples, kRateHz, kWhiteUg, 0, 300, rise_y_ug, rng, kFilterS);
  };
  DwellSampleCorrelation run(1 / kRateHz, kG);
  for (int k = 0; k < 4; ++k) (void)add_dwell(run, dwell());  // the run's dwells so far
  const std::array<double, 3> after_four = run.widening();
  std::printf("widening with four dwells pooled: x %.3f y %.3f z %.3f\n", after_four[0],
              after_four[1], after_four[2]);
  for (const double w : after_four) EXPECT_NEAR(w, 2.02, 0.2);
  StabilityRule rule;
  rule.trend_limit_sigmas = 3;
  std::array<double, 3> z2{};
  int remeasured = 0;
  for (int k = 0; k < kDwells; ++k) {
    const auto samples = dwell();
    const DwellAverage d = average_dwell(samples);
    DwellExpectation e = expect(10, kRateHz);
    e.sample_correlation_widening = run.add_dwell(samples, d);
    for (int a = 0; a < 3; ++a)
      z2[a] += std::pow(d.trend_mps2[a] / explained_trend_sigma_mps2(
                                              d, a, 0, 300, e.sample_correlation_widening[a]),
                        2) /
               kDwells;
    if (!dwell_problem(d, e, rule).empty()) ++remeasured;
  }
  std::printf(
      "filtered unit: drift z-variance x %.3f y %.3f z %.3f, %d of %d quiet dwells "
      "re-measured\n",
      z2[0], z2[1], z2[2], remeasured, kDwells);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(z2[a], 1, 0.15) << axis_name(a);  // sd 0.03 each
  EXPECT_LE(remeasured, kDwells * 2 / 100);
  // A drift beyond it is still one, and the operator is told what was allowed for.
  const auto drifting = dwell(400);
  DwellExpectation e = expect(10, kRateHz);
  e.sample_correlation_widening = add_dwell(run, drifting);
  const std::string problem = dwell_problem(average_dwell(drifting), e, rule);
  ASSERT_EQ(problem.rfind("axis y drifted ", 0), 0u) << problem;
  EXPECT_NE(problem.find("µg from its sample σ widened 2."), std::string::npos) << problem;
  EXPECT_NE(problem.find("times for its correlated samples; limit 3 times)"), std::string::npos)
      << problem;
}

// The first dwell of a run is judged with only itself pooled. A filter of one sample period
// (widening 1.47) is shown by the first dwell of 250 samples (10 s at 25 Hz), and one of two
// periods (2.02) by a first dwell of 100, in 98 and 100 of 100 seeded runs; dwells that do not show
// it are judged as white (the rule as it was), and the next dwell, re-measured or not, is pooled
// beside them.
TEST(DwellStability, AFirstDwellShowsTheFilter) {
  STANDCAL_STATISTICAL_TEST();
  std::mt19937_64 rng(53);
  constexpr int kRuns = 100;
  for (const auto& [samples, filter_s] : {std::pair{250, 0.04}, std::pair{100, 0.08}}) {
    int shown = 0;
    for (int r = 0; r < kRuns; ++r) {
      DwellSampleCorrelation run(1 / 25.0, kG);
      shown += add_dwell(run, noisy_dwell(samples, 25, 200, 0, 300, 0, rng, filter_s))[0] > 1.3;
    }
    std::printf("a filter of %.2f s shown by a first dwell of %d samples in %d of %d runs\n",
                filter_s, samples, shown, kRuns);
    EXPECT_GE(shown, kRuns * 95 / 100) << samples << " samples, filter " << filter_s << " s";
  }
}

// A resumed run pools the dwells of its recording file as the run before the restart had
// pooled them: the same widening. Its warm-up (header warmup_s), which the run did not pool,
// is left out: pooled, a minute's warm-up with the unit settling by 500 ug had moved the
// widening by up to 1 % (1.984 for 1.964).
TEST(DwellStability, AResumedRunPoolsItsRecordingsDwellsAsTheyWereMeasured) {
  std::mt19937_64 rng(47);
  DwellSampleCorrelation measured(1 / 25.0, kG);
  Recording rec;
  rec.g_local_mps2 = kG;
  rec.sample_rate_hz = 25;
  rec.columns = RecordingColumns{};
  rec.set_header(kHeaderWarmupS, "59.98");  // its last row half a period before the dwell
  const auto warm_up = noisy_dwell(1500, 25, 200, 0, 300, 0, rng, 0.08);
  for (std::size_t i = 0; i < warm_up.size(); ++i) {
    RecordingSample row;
    row.t_s = warm_up[i].t_s - 60;
    row.f_mps2 = Vec3(warm_up[i].force_mps2[0], warm_up[i].force_mps2[1],
                      warm_up[i].force_mps2[2] + 500 * kUgMps2 * std::exp(-(row.t_s - 940) / 20));
    rec.samples.push_back(row);
  }
  for (int pos = 0; pos < 3; ++pos) {
    const auto samples = noisy_dwell(250, 25, 200, 0, 300, 0, rng, 0.08);
    (void)add_dwell(measured, samples);
    for (const auto& x : samples) {
      RecordingSample row;
      row.t_s = x.t_s + 20 * pos;
      row.pos = pos;
      row.f_mps2 = Vec3(x.force_mps2[0], x.force_mps2[1], x.force_mps2[2]);
      rec.samples.push_back(row);
    }
  }
  test::TempDir dir{"standcal-dwell-pool"};
  write_recording(rec, dir.file("recording.csv"));
  DwellSampleCorrelation resumed(1 / 25.0, kG);
  resumed.add_recorded_dwells(dir.file("recording.csv"));
  const std::array<double, 3> widening = measured.widening();
  const std::array<double, 3> resumed_widening = resumed.widening();
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(widening[a], 1.5) << a;
    // The file keeps ten significant digits of each sample.
    EXPECT_NEAR(resumed_widening[a], widening[a], 1e-6) << a;
  }
}

// A white unit's dwells, pooled, show no correlation: its drift rule is as it was.
TEST(DwellStability, AWhiteUnitsDwellsAreNotWidened) {
  std::mt19937_64 rng(43);
  DwellSampleCorrelation run(1 / 25.0, kG);
  for (int k = 0; k < 8; ++k) {
    const std::array<double, 3> widening =
        add_dwell(run, noisy_dwell(250, 25, 200, 0, 300, 0, rng));
    EXPECT_EQ(widening, (std::array<double, 3>{1, 1, 1})) << "dwell " << k;
  }
}

}  // namespace
}  // namespace standcal::daemon
