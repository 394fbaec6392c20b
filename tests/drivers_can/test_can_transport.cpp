// The SocketCAN unit driver fed real CAN frame bytes over a socketpair: joining,
// loss, duplication, reordering, counter wrap, error frames, silence, CAN FD.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <nlohmann/json.hpp>
#include <thread>

#include "can_pair.hpp"
#include "drivers/socketcan/socketcan_unit.hpp"

namespace standcal::drivers::can {
namespace {

using testing::CanPair;
using testing::DelayedWriter;

constexpr double kWriterDelay_s = 0.15;  // the writer starts once collect() is waiting

double realtime_s() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

std::array<double, 3> force_of(std::uint64_t n) {
  return {1e-3 * kStandardGravity_mps2 * static_cast<double>(n), -0.5 * kStandardGravity_mps2,
          kStandardGravity_mps2};
}

class CanTransport : public ::testing::Test {
 protected:
  // Silence timeout longer than the collect windows: the writers send one burst.
  void open_unit(SocketCanUnitConfig config = {2.0, 4}) {
    unit_fd_ = pair_.release_unit_fd();
    auto u = SocketCanUnit::adopt_fd(unit_fd_, layout_, config);
    ASSERT_TRUE(u.ok()) << u.status().message;
    unit_ = std::move(u.value());
    ASSERT_TRUE(unit_->start());
  }
  // All frames of sample n, in layout order (x, y, z, temperature).
  std::vector<EncodedFrame> frames_of(std::uint64_t n) const {
    return layout_.encode(force_of(n), 21.5, n);
  }
  void send_sample(std::uint64_t n) const {
    for (const auto& f : frames_of(n)) pair_.send(f);
  }
  // A 0.4 s collect (or collect_more) while the unit sends samples [from, to) once it waits.
  Result<std::vector<AccelSample>> collect_while_sent(std::uint64_t from, std::uint64_t to,
                                                      bool more = false) {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = from; n < to; ++n) send_sample(n);
    });
    return more ? unit_->collect_more(0.4) : unit_->collect(0.4);
  }

  FrameLayout layout_ = FrameLayout::default_layout();
  CanPair pair_;
  int unit_fd_ = -1;
  std::unique_ptr<SocketCanUnit> unit_;
};

TEST_F(CanTransport, JoinsRealFramesIntoTimestampedSamples) {
  open_unit();
  const double before_s = realtime_s();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 100; n < 150; ++n) send_sample(n);
    });
    r = unit_->collect(0.8);
  }
  const double after_s = realtime_s();
  ASSERT_TRUE(r.ok()) << r.status().message;
  const auto& samples = r.value();
  ASSERT_EQ(samples.size(), 50U);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    EXPECT_EQ(s.counter, 100 + i);
    const auto expected = force_of(100 + i);
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(s.force_mps2[static_cast<std::size_t>(a)], expected[static_cast<std::size_t>(a)],
                  1e-6);
    // The temperature frame follows the force frames: the first sample has none yet.
    if (i == 0) {
      EXPECT_TRUE(std::isnan(s.temperature_c));
    } else {
      EXPECT_NEAR(s.temperature_c, 21.5, 1e-9);
    }
    EXPECT_GE(s.t_s, before_s);
    EXPECT_LE(s.t_s, after_s);
    if (i > 0) {
      EXPECT_GE(s.t_s, samples[i - 1].t_s);
    }
  }
  const auto h = unit_->health();
  EXPECT_EQ(h.frames, 200U);
  EXPECT_EQ(h.samples, 50U);
  EXPECT_EQ(h.incomplete_samples, 0U);
  EXPECT_EQ(h.bus_state, BusState::error_active);
  EXPECT_FALSE(h.silent);
}

TEST_F(CanTransport, LossDuplicationAndReorderingAreCountedNotInterpolated) {
  open_unit();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 0; n < 40; ++n) {
        const auto f = frames_of(n);  // x, y, z, temperature
        if (n == 10) {
          for (std::size_t i : {0, 2, 3}) pair_.send(f[i]);  // y frame of sample 10 lost
        } else if (n == 20) {
          for (std::size_t i : {0, 1, 2, 3, 0})
            pair_.send(f[i]);  // x frame of sample 20 duplicated
        } else if (n == 30) {
          const auto next = frames_of(31);
          for (std::size_t i : {2, 1}) pair_.send(f[i]);  // z before y ...
          pair_.send(next[0]);                            // ... sample 31 overtakes ...
          for (std::size_t i : {0, 3}) pair_.send(f[i]);  // ... and x of 30 comes last
          for (std::size_t i : {1, 2, 3}) pair_.send(next[i]);
        } else if (n != 31) {
          for (const auto& g : f) pair_.send(g);
        }
      }
    });
    r = unit_->collect(0.8);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  std::vector<std::uint64_t> counters;
  for (const auto& s : r.value()) counters.push_back(s.counter);
  std::vector<std::uint64_t> expected;
  for (std::uint64_t n = 0; n < 40; ++n)
    if (n != 10) expected.push_back(n);
  EXPECT_EQ(counters, expected);  // in counter order, sample 10 missing, none invented
  const auto h = unit_->health();
  EXPECT_EQ(h.incomplete_samples, 1U);
  EXPECT_EQ(h.duplicate_frames, 1U);
  EXPECT_EQ(h.late_frames, 0U);
}

TEST_F(CanTransport, FramesLaterThanTheJoinWindowMakeTheirSampleIncomplete) {
  open_unit({2.0, 2});
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      const auto late = frames_of(5);
      for (std::uint64_t n = 0; n < 12; ++n) {
        const auto f = frames_of(n);
        for (std::size_t i = 0; i < f.size(); ++i)
          if (!(n == 5 && i == 2)) pair_.send(f[i]);  // z of sample 5 held back
      }
      pair_.send(late[2]);  // z of sample 5, 6 samples late
    });
    r = unit_->collect(0.8);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().size(), 11U);
  EXPECT_EQ(unit_->health().incomplete_samples, 1U);
  EXPECT_EQ(unit_->health().late_frames, 1U);
}

TEST_F(CanTransport, SixteenBitCounterWrapIsSeamless) {
  open_unit();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 65530; n < 65545; ++n) send_sample(n);  // encoded mod 65536
    });
    r = unit_->collect(0.8);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  ASSERT_EQ(r.value().size(), 15U);
  EXPECT_EQ(r.value().front().counter, 65530U);
  EXPECT_EQ(r.value().back().counter, 65544U);
  EXPECT_EQ(unit_->health().incomplete_samples, 0U);
  EXPECT_EQ(unit_->health().counter_resyncs, 0U);
}

TEST_F(CanTransport, ErrorFramesReportErrorPassiveAndRestarts) {
  open_unit();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      send_sample(0);
      pair_.send_error(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE);
      send_sample(1);
    });
    r = unit_->collect(0.5);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().size(), 2U);
  EXPECT_EQ(unit_->health().bus_state, BusState::error_passive);
  EXPECT_EQ(unit_->health().error_frames, 1U);
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      pair_.send_error(CAN_ERR_RESTARTED);
      send_sample(2);
    });
    r = unit_->collect(0.5);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(unit_->health().bus_state, BusState::error_active);
  EXPECT_EQ(unit_->health().restarts, 1U);
}

TEST_F(CanTransport, BusOffFailsSamplingWithAClearError) {
  open_unit();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      send_sample(0);
      pair_.send_error(CAN_ERR_BUSOFF);
    });
    r = unit_->collect(5.0);
  }
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().kind, ErrorKind::link);
  EXPECT_EQ(r.status().message, "CAN controller of fd " + std::to_string(unit_fd_) +
                                    " went bus-off while sampling the accelerometer unit");
  EXPECT_EQ(unit_->health().bus_state, BusState::bus_off);
}

// A bus-off between two collects (queued before this one starts) with no restart after it
// fails the call at once with a clear error (it used to be read, then forgotten, and the
// call waited out its silence timeout); one followed by a restart does not.
TEST_F(CanTransport, ABusOffBeforeSamplingFailsItUnlessTheControllerRestarted) {
  open_unit();
  pair_.send_error(CAN_ERR_BUSOFF);
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 0; n < 5; ++n) send_sample(n);
    });
    r = unit_->collect(0.5);
  }
  ASSERT_FALSE(r.ok()) << r.value().size() << " samples accepted from a bus-off controller";
  EXPECT_EQ(r.status().kind, ErrorKind::link);
  EXPECT_EQ(r.status().message, "CAN controller of fd " + std::to_string(unit_fd_) +
                                    " is bus-off (no restart since); the accelerometer unit "
                                    "cannot be sampled");

  pair_.send_error(CAN_ERR_BUSOFF);
  pair_.send_error(CAN_ERR_RESTARTED);
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 5; n < 10; ++n) send_sample(n);
    });
    r = unit_->collect(0.5);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().size(), 5U);
  EXPECT_EQ(unit_->health().bus_state, BusState::error_active);
}

TEST_F(CanTransport, SilenceFailsSamplingInProgress) {
  open_unit({0.3, 4});
  const auto t0 = std::chrono::steady_clock::now();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 0; n < 5; ++n) send_sample(n);
      pair_.send(frames_of(5)[0]);  // then the unit stops mid-sample
    });
    r = unit_->collect(10.0);
  }
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().kind, ErrorKind::timeout);
  EXPECT_EQ(r.status().message, "no CAN frame from the accelerometer unit on fd " +
                                    std::to_string(unit_fd_) + " for 0.3 s");
  EXPECT_LT(elapsed_s, 5.0);  // failed on silence, not at the end of the 10 s window
  EXPECT_TRUE(unit_->health().silent);
  EXPECT_EQ(unit_->health().incomplete_samples, 1U);  // the half sample
}

TEST_F(CanTransport, AUnitSilentFromTheStartFails) {
  open_unit({0.2, 4});
  auto r = unit_->collect(3.0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message.find("no CAN frame from the accelerometer unit"), std::string::npos);
}

TEST_F(CanTransport, TheOtherEndClosingIsALinkError) {
  open_unit();
  pair_.close_bus();
  auto r = unit_->collect(1.0);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().kind, ErrorKind::link);
  EXPECT_NE(r.status().message.find("closed by the other end"), std::string::npos);
}

TEST_F(CanTransport, FramesQueuedBeforeCollectAreNotPartOfIt) {
  open_unit();
  for (std::uint64_t n = 0; n < 10; ++n) send_sample(n);
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 10; n < 15; ++n) send_sample(n);
    });
    r = unit_->collect(0.6);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  ASSERT_EQ(r.value().size(), 5U);
  EXPECT_EQ(r.value().front().counter, 10U);
  EXPECT_EQ(unit_->health().frames, 60U);  // the stale ones were still read and counted
}

// A dwell is collected in chunks: what the unit sends while the caller is busy between two
// is the start of the next (collect_more), not lost; a plain collect still begins at its call
// (the stand may have moved since). Every collect had dropped what queued before it.
TEST_F(CanTransport, CollectMoreLosesNothingSinceThePreviousCollect) {
  open_unit();
  const Result<std::vector<AccelSample>> first = collect_while_sent(0, 5);
  ASSERT_TRUE(first.ok()) << first.status().message;
  ASSERT_EQ(first.value().size(), 5U);
  for (std::uint64_t n = 5; n < 10; ++n) send_sample(n);  // the caller is busy
  const Result<std::vector<AccelSample>> next = collect_while_sent(10, 15, true);
  ASSERT_TRUE(next.ok()) << next.status().message;
  ASSERT_EQ(next.value().size(), 10U);
  for (std::size_t i = 0; i < 10; ++i) EXPECT_EQ(next.value()[i].counter, 5 + i);
  // A plain collect begins at its call.
  for (std::uint64_t n = 15; n < 20; ++n) send_sample(n);
  const Result<std::vector<AccelSample>> plain = collect_while_sent(20, 23);
  ASSERT_TRUE(plain.ok()) << plain.status().message;
  ASSERT_EQ(plain.value().size(), 3U);
  EXPECT_EQ(plain.value().front().counter, 20U);
  // So does the first collect_more after a new start().
  ASSERT_TRUE(unit_->stop());
  ASSERT_TRUE(unit_->start());
  for (std::uint64_t n = 23; n < 28; ++n) send_sample(n);
  const Result<std::vector<AccelSample>> after_start = collect_while_sent(28, 31, true);
  ASSERT_TRUE(after_start.ok()) << after_start.status().message;
  ASSERT_EQ(after_start.value().size(), 3U);
  EXPECT_EQ(after_start.value().front().counter, 28U);
}

// A caller late for its next chunk gets that chunk's window, from where the last one ended,
// at once; what the kernel received after the window is the next chunk's. So a dwell's chunks
// add up to its span however late each call comes (a window begun at the call had made a
// dwell timed by its caller short or long by the caller's lag).
TEST_F(CanTransport, ALateCollectMoreGetsItsWindowAndLeavesTheRestForTheNext) {
  open_unit();
  const Result<std::vector<AccelSample>> first = collect_while_sent(0, 5);
  ASSERT_TRUE(first.ok()) << first.status().message;
  ASSERT_EQ(first.value().size(), 5U);
  // The next window is the 0.4 s after the first: the caller comes 0.6 s late, and the unit
  // sent samples 5-9 inside that window and 10-14 after it.
  for (std::uint64_t n = 5; n < 10; ++n) send_sample(n);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (std::uint64_t n = 10; n < 15; ++n) send_sample(n);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const Result<std::vector<AccelSample>> late = unit_->collect_more(0.4);
  ASSERT_TRUE(late.ok()) << late.status().message;
  ASSERT_EQ(late.value().size(), 5U);
  EXPECT_EQ(late.value().front().counter, 5U);
  const Result<std::vector<AccelSample>> next = unit_->collect_more(0.4);
  ASSERT_TRUE(next.ok()) << next.status().message;
  ASSERT_EQ(next.value().size(), 5U);
  EXPECT_EQ(next.value().front().counter, 10U);
  // What a late call holds back does not outlive the series: a start() drops it.
  for (std::uint64_t n = 15; n < 20; ++n) send_sample(n);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const Result<std::vector<AccelSample>> third = unit_->collect_more(0.4);  // 1.2-1.6 s
  ASSERT_TRUE(third.ok()) << third.status().message;
  ASSERT_EQ(third.value().size(), 5U);  // 15-19
  for (std::uint64_t n = 20; n < 25; ++n) send_sample(n);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const Result<std::vector<AccelSample>> fourth = unit_->collect_more(0.1);  // 1.6-1.7 s
  ASSERT_TRUE(fourth.ok()) << fourth.status().message;
  ASSERT_EQ(fourth.value().size(), 0U);  // 20-24, sent at 1.9 s, are held
  ASSERT_TRUE(unit_->stop());
  ASSERT_TRUE(unit_->start());
  const Result<std::vector<AccelSample>> fresh = collect_while_sent(25, 28, true);
  ASSERT_TRUE(fresh.ok()) << fresh.status().message;
  ASSERT_EQ(fresh.value().size(), 3U);
  EXPECT_EQ(fresh.value().front().counter, 25U);
}

// The silence timeout runs from when the unit last sent, not from when a late caller read
// its frames: a unit that fell silent while the caller was busy is reported, although the
// frames it sent before are still queued (reading them had counted as hearing from it).
TEST_F(CanTransport, ALateCallerStillFindsAUnitThatFellSilent) {
  open_unit({0.3, 4});
  const Result<std::vector<AccelSample>> first = collect_while_sent(0, 5);
  ASSERT_TRUE(first.ok()) << first.status().message;
  for (std::uint64_t n = 5; n < 10; ++n) send_sample(n);
  std::this_thread::sleep_for(std::chrono::milliseconds(800));  // and then nothing
  const Result<std::vector<AccelSample>> late = unit_->collect_more(0.4);
  ASSERT_FALSE(late.ok());
  EXPECT_NE(late.status().message.find("no CAN frame from the accelerometer unit"),
            std::string::npos)
      << late.status().message;
  EXPECT_TRUE(unit_->health().silent);
}

TEST_F(CanTransport, UnknownIdsAndRemoteFramesAreCountedAndIgnored) {
  open_unit();
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      const std::uint8_t d[8] = {};
      pair_.send_classic(0x7FF, d, 8);
      pair_.send_classic(0x101 | CAN_RTR_FLAG, d, 0);
      send_sample(0);
    });
    r = unit_->collect(0.5);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().size(), 1U);
  EXPECT_EQ(unit_->health().unknown_frames, 2U);
}

TEST_F(CanTransport, CollectBeforeStartIsRefused) {
  auto u = SocketCanUnit::adopt_fd(pair_.release_unit_fd(), layout_);
  ASSERT_TRUE(u.ok());
  auto r = u.value()->collect(0.1);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().kind, ErrorKind::not_allowed);
}

TEST(CanTransportFd, CanFdFramesCarryAllThreeAxes) {
  nlohmann::json j;
  j["signals"] = nlohmann::json::array();
  const char* roles[3] = {"force_x", "force_y", "force_z"};
  for (int i = 0; i < 3; ++i)
    j["signals"].push_back({{"role", roles[i]},
                            {"can_id", "0x200"},
                            {"start_bit", 32 * i},
                            {"length", 32},
                            {"signed", true},
                            {"scale", 1e-7},
                            {"unit", "g"}});
  j["signals"].push_back(
      {{"role", "counter"}, {"can_id", "0x200"}, {"start_bit", 96}, {"length", 16}});
  j["signals"].push_back({{"role", "temperature"},
                          {"can_id", "0x200"},
                          {"start_bit", 112},
                          {"length", 16},
                          {"signed", true},
                          {"scale", 0.01},
                          {"unit", "degC"}});
  auto layout = FrameLayout::from_json(j);
  ASSERT_TRUE(layout.ok()) << layout.status().message;
  CanPair pair;
  auto u = SocketCanUnit::adopt_fd(pair.release_unit_fd(), layout.value());
  ASSERT_TRUE(u.ok());
  auto& unit = *u.value();
  ASSERT_TRUE(unit.start());
  Result<std::vector<AccelSample>> r = Status::ok();
  {
    DelayedWriter w(kWriterDelay_s, [&] {
      for (std::uint64_t n = 0; n < 3; ++n) {
        const auto f =
            layout.value().encode({0.1 * kStandardGravity_mps2, 0.2 * kStandardGravity_mps2,
                                   -0.3 * kStandardGravity_mps2},
                                  30.0, n);
        ASSERT_EQ(f.size(), 1U);
        ASSERT_EQ(f[0].len, 16);  // 16 bytes: only CAN FD carries it
        pair.send_fd(f[0].can_id, f[0].data.data(), f[0].len);
      }
    });
    r = unit.collect(0.5);
  }
  ASSERT_TRUE(r.ok()) << r.status().message;
  ASSERT_EQ(r.value().size(), 3U);
  EXPECT_NEAR(r.value()[2].force_mps2[2], -0.3 * kStandardGravity_mps2, 1e-6);
  EXPECT_NEAR(r.value()[2].temperature_c, 30.0, 1e-9);
}

}  // namespace
}  // namespace standcal::drivers::can
