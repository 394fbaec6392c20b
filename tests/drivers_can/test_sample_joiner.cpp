// Joining per-axis frames into samples by counter: loss, duplication, reordering,
// lateness, counter wrap and unit restarts, without any I/O.
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/socketcan/sample_joiner.hpp"

namespace standcal::drivers::can {
namespace {

FrameValues axis_frame(int axis, std::uint64_t counter, double value) {
  FrameValues f;
  f.force_mps2[static_cast<std::size_t>(axis)] = value;
  f.force_mask = static_cast<std::uint8_t>(1U << axis);
  f.counter = counter;
  f.has_counter = true;
  return f;
}

struct JoinerRun {
  SampleJoiner joiner{65536, 4};
  std::vector<AccelSample> out;
  void send(int axis, std::uint64_t counter) {
    joiner.add(axis_frame(axis, counter % 65536, 1000.0 * axis + static_cast<double>(counter)),
               static_cast<double>(counter), out);
  }
  void send_sample(std::uint64_t counter) {
    for (int a = 0; a < 3; ++a) send(a, counter);
  }
  std::vector<std::uint64_t> counters() const {
    std::vector<std::uint64_t> c;
    for (const auto& s : out) c.push_back(s.counter);
    return c;
  }
};

TEST(SampleJoiner, JoinsTheThreeAxesOfOneCounter) {
  JoinerRun r;
  for (std::uint64_t n = 10; n < 15; ++n) r.send_sample(n);
  ASSERT_EQ(r.counters(), (std::vector<std::uint64_t>{10, 11, 12, 13, 14}));
  EXPECT_DOUBLE_EQ(r.out[2].force_mps2[0], 12.0);
  EXPECT_DOUBLE_EQ(r.out[2].force_mps2[1], 1012.0);
  EXPECT_DOUBLE_EQ(r.out[2].force_mps2[2], 2012.0);
  EXPECT_DOUBLE_EQ(r.out[2].t_s, 12.0);
  EXPECT_TRUE(std::isnan(r.out[0].temperature_c));  // no temperature frame yet
  EXPECT_EQ(r.joiner.counters().samples, 5U);
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 0U);
}

TEST(SampleJoiner, AMissingFrameMakesItsSampleIncompleteNeverInterpolated) {
  JoinerRun r;
  for (std::uint64_t n = 0; n < 10; ++n) {
    for (int a = 0; a < 3; ++a)
      if (!(n == 4 && a == 1)) r.send(a, n);
  }
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{0, 1, 2, 3, 5, 6, 7, 8, 9}));
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 1U);
}

TEST(SampleJoiner, SamplesWithNoFrameAtAllCountAsIncomplete) {
  JoinerRun r;
  r.send_sample(0);
  r.send_sample(1);
  r.send_sample(5);  // 2, 3, 4 lost entirely
  for (std::uint64_t n = 6; n < 10; ++n) r.send_sample(n);
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{0, 1, 5, 6, 7, 8, 9}));
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 3U);
}

TEST(SampleJoiner, DuplicatesAreCountedAndIgnored) {
  JoinerRun r;
  r.send(0, 0);
  r.send(0, 0);  // duplicate while the sample is pending
  r.send(1, 0);
  r.send(2, 0);
  r.send(2, 0);  // duplicate after the sample was delivered
  r.send_sample(1);
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{0, 1}));
  EXPECT_EQ(r.joiner.counters().duplicate_frames, 2U);
  EXPECT_EQ(r.joiner.counters().late_frames, 0U);
}

TEST(SampleJoiner, ReorderedFramesWithinTheWindowStillJoinInCounterOrder) {
  JoinerRun r;
  r.send(0, 1);  // the very first frame belongs to the second sample
  r.send_sample(0);
  r.send(1, 1);
  r.send(2, 1);
  r.send(0, 3);  // sample 3 starts before sample 2
  r.send(0, 2);
  r.send(1, 3);
  r.send(2, 3);  // sample 3 complete before sample 2: held back
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{0, 1}));
  r.send(2, 2);
  r.send(1, 2);
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{0, 1, 2, 3}));
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 0U);
  EXPECT_EQ(r.joiner.counters().late_frames, 0U);
}

TEST(SampleJoiner, AFrameLaterThanTheWindowIsLateAndItsSampleIncomplete) {
  JoinerRun r;
  r.send(0, 0);
  r.send(1, 0);
  for (std::uint64_t n = 1; n <= 4; ++n) r.send_sample(n);  // 4 samples newer: sample 0 given up
  r.send(2, 0);                                             // arrives too late
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{1, 2, 3, 4}));
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 1U);
  EXPECT_EQ(r.joiner.counters().late_frames, 1U);
}

TEST(SampleJoiner, CounterWrapKeepsCounting) {
  JoinerRun r;
  for (std::uint64_t n = 65533; n < 65540; ++n) r.send_sample(n);  // sent as n mod 65536
  EXPECT_EQ(r.counters(),
            (std::vector<std::uint64_t>{65533, 65534, 65535, 65536, 65537, 65538, 65539}));
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 0U);
}

TEST(SampleJoiner, LossAcrossTheWrapIsCounted) {
  SampleJoiner j(256, 4);  // 8-bit counter
  std::vector<AccelSample> out;
  for (std::uint64_t n = 250; n < 262; ++n) {
    if (n == 256) continue;  // the sample with counter 0 is lost
    for (int a = 0; a < 3; ++a) j.add(axis_frame(a, n % 256, 1), 0, out);
  }
  EXPECT_EQ(out.size(), 11U);
  EXPECT_EQ(j.counters().incomplete_samples, 1U);
  EXPECT_EQ(out.back().counter, 261U);
}

TEST(SampleJoiner, AUnitRestartResynchronisesInsteadOfCountingThousandsLost) {
  JoinerRun r;
  for (std::uint64_t n = 5000; n < 5005; ++n) r.send_sample(n);
  r.send(0, 5005);  // a half sample in progress when the unit restarts
  for (std::uint64_t n = 0; n < 5; ++n) r.send_sample(n);
  EXPECT_EQ(r.joiner.counters().counter_resyncs, 1U);
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 1U);
  EXPECT_EQ(r.out.size(), 10U);
  EXPECT_EQ(r.out.back().counter, 4U);
}

TEST(SampleJoiner, TemperatureIsAttachedFromTheLatestTemperatureFrame) {
  JoinerRun r;
  FrameValues t;
  t.has_temperature = true;
  t.temperature_c = 23.25;
  r.joiner.add(t, 0, r.out);
  r.send_sample(0);
  ASSERT_EQ(r.out.size(), 1U);
  EXPECT_DOUBLE_EQ(r.out[0].temperature_c, 23.25);
}

TEST(SampleJoiner, ResetCountsSamplesInProgressAsIncomplete) {
  JoinerRun r;
  r.send(0, 7);
  r.send(1, 7);
  r.joiner.reset();
  EXPECT_EQ(r.joiner.counters().incomplete_samples, 1U);
  r.send_sample(100);  // after a reset any counter starts a new sequence
  EXPECT_EQ(r.counters(), (std::vector<std::uint64_t>{100}));
}

}  // namespace
}  // namespace standcal::drivers::can
