// The AccelUnit contract (issue 18, item 1): the same cases over the simulated unit and
// the SocketCAN unit fed real `struct can_frame` bytes over a socketpair (this kernel has
// no CAN; tests/drivers_can/test_vcan.cpp runs on a real interface where there is one).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>

#include "drivers/sim/sim_backend.hpp"
#include "drivers/socketcan/socketcan_unit.hpp"
#include "tests/drivers_can/can_pair.hpp"

namespace standcal::drivers {
namespace {

constexpr double kRate_hz = 100;

// The simulated unit on the simulated stand at rest, 10× faster than real time.
class SimUnitBackend {
 public:
  SimUnitBackend() {
    SimBackendConfig config;
    config.time_scale = 10;
    config.sample_rate_hz = kRate_hz;
    backend_ = make_sim_backend(config);
  }
  AccelUnit& unit() { return *backend_.unit; }
  void set_silent(bool silent) { backend_.set_unit_silent(silent); }

 private:
  SimBackend backend_;
};

// The SocketCAN unit; a thread plays the unit, sending every sample's frames at 100 Hz
// (specific force (0, 0, g): a unit at rest, z up) until it is told to fall silent.
class SocketCanUnitBackend {
 public:
  SocketCanUnitBackend() {
    auto unit = can::SocketCanUnit::adopt_fd(pair_.release_unit_fd(), layout_, {0.3, 4});
    if (!unit) throw std::runtime_error(unit.status().message);
    unit_ = std::move(unit.value());
    feeder_ = std::thread([this] { feed(); });
  }
  ~SocketCanUnitBackend() {
    quit_ = true;
    feeder_.join();
  }
  AccelUnit& unit() { return *unit_; }
  void set_silent(bool silent) { silent_ = silent; }

 private:
  void feed() {
    std::uint64_t n = 0;
    auto next = std::chrono::steady_clock::now();
    while (!quit_) {
      if (!silent_) {
        for (const auto& frame : layout_.encode({0.0, 0.0, can::kStandardGravity_mps2}, 22.0, n))
          pair_.send(frame);
        ++n;
      }
      next += std::chrono::microseconds(static_cast<long>(1e6 / kRate_hz));
      std::this_thread::sleep_until(next);
    }
  }

  can::FrameLayout layout_ = can::FrameLayout::default_layout();
  can::testing::CanPair pair_;
  std::unique_ptr<can::SocketCanUnit> unit_;
  std::atomic<bool> quit_{false};
  std::atomic<bool> silent_{false};
  std::thread feeder_;  // last: starts after everything it uses
};

template <class Backend>
class UnitContract : public ::testing::Test {
 protected:
  AccelUnit& unit() { return backend_.unit(); }
  Backend backend_;
};

using UnitBackends = ::testing::Types<SimUnitBackend, SocketCanUnitBackend>;
class UnitBackendNames {
 public:
  template <class T>
  static std::string GetName(int) {
    return std::is_same_v<T, SimUnitBackend> ? "sim" : "socketcan";
  }
};
TYPED_TEST_SUITE(UnitContract, UnitBackends, UnitBackendNames);

TYPED_TEST(UnitContract, CollectIsRefusedUntilStartedAndAfterStop) {
  EXPECT_EQ(this->unit().collect(0.1).status().kind, ErrorKind::not_allowed);
  ASSERT_TRUE(this->unit().start());
  EXPECT_TRUE(this->unit().collect(0.1));
  ASSERT_TRUE(this->unit().stop());
  const auto stopped = this->unit().collect(0.1);
  EXPECT_EQ(stopped.status().kind, ErrorKind::not_allowed);
  EXPECT_NE(stopped.status().message.find("not started"), std::string::npos)
      << stopped.status().message;
}

TYPED_TEST(UnitContract, ANonPositiveDurationIsAnInvalidArgument) {
  ASSERT_TRUE(this->unit().start());
  EXPECT_EQ(this->unit().collect(0).status().kind, ErrorKind::invalid_argument);
  EXPECT_EQ(this->unit().collect(-1).status().kind, ErrorKind::invalid_argument);
  EXPECT_EQ(this->unit().collect(std::nan("")).status().kind, ErrorKind::invalid_argument);
}

TYPED_TEST(UnitContract, SamplesComeInOrderAtTheRateWithGravity) {
  ASSERT_TRUE(this->unit().start());
  const auto collected = this->unit().collect(0.5);
  ASSERT_TRUE(collected) << collected.status().message;
  const auto& samples = collected.value();
  // 50 samples in 0.5 s at 100 Hz; a sample straddling either end may fall on either side.
  EXPECT_GE(samples.size(), 45u);
  EXPECT_LE(samples.size(), 52u);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const AccelSample& s = samples[i];
    const double f_mps2 = std::hypot(s.force_mps2[0], s.force_mps2[1], s.force_mps2[2]);
    EXPECT_NEAR(f_mps2, 9.81, 0.2) << "sample " << i << ": a unit at rest measures gravity";
    if (i == 0) continue;
    EXPECT_EQ(s.counter, samples[i - 1].counter + 1) << "sample " << i;
    EXPECT_GT(s.t_s, samples[i - 1].t_s) << "sample " << i;
  }
  EXPECT_GE(this->unit().health().samples, samples.size());
}

TYPED_TEST(UnitContract, ASilentUnitFailsTheCollectSayingSoAndRecoversWhenItTalks) {
  ASSERT_TRUE(this->unit().start());
  ASSERT_TRUE(this->unit().collect(0.1));
  this->backend_.set_silent(true);
  const auto silent = this->unit().collect(1.0);
  ASSERT_FALSE(silent);
  EXPECT_EQ(silent.status().kind, ErrorKind::timeout);
  EXPECT_NE(silent.status().message.find("from the accelerometer unit"), std::string::npos)
      << silent.status().message;
  EXPECT_TRUE(this->unit().health().silent);
  this->backend_.set_silent(false);
  const auto again = this->unit().collect(0.3);
  ASSERT_TRUE(again) << again.status().message;
  EXPECT_FALSE(again.value().empty());
  EXPECT_FALSE(this->unit().health().silent);
}

}  // namespace
}  // namespace standcal::drivers
