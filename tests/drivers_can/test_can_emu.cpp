// The emulator process (standcal-can-emu) driving the real driver through an inherited
// fd, and the `standcal unit read` command reading the emulator.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "can_pair.hpp"
#include "child_process.hpp"
#include "drivers/socketcan/socketcan_unit.hpp"

namespace standcal::drivers::can {
namespace {

using testing::CanPair;
using testing::ChildProcess;

constexpr double kDeg = 3.14159265358979323846 / 180;

struct AxisStats {
  double mean = 0, sigma = 0;
};

AxisStats stats(const std::vector<AccelSample>& samples, std::size_t axis) {
  AxisStats s;
  for (const auto& a : samples) s.mean += a.force_mps2[axis];
  s.mean /= static_cast<double>(samples.size());
  for (const auto& a : samples) s.sigma += std::pow(a.force_mps2[axis] - s.mean, 2);
  s.sigma = std::sqrt(s.sigma / static_cast<double>(samples.size() - 1));
  return s;
}

class CanEmu : public ::testing::Test {
 protected:
  // Starts the emulator on the bus end of the pair and the driver on the other.
  void start_emu(std::vector<std::string> flags, SocketCanUnitConfig config = {0.5, 4}) {
    std::vector<std::string> argv{STANDCAL_CAN_EMU_PATH, "--fd", std::to_string(pair_.bus_fd())};
    argv.insert(argv.end(), flags.begin(), flags.end());
    emu_ = std::make_unique<ChildProcess>(argv, pair_.bus_fd());
    pair_.close_bus();  // the emulator holds its copy
    auto u =
        SocketCanUnit::adopt_fd(pair_.release_unit_fd(), FrameLayout::default_layout(), config);
    ASSERT_TRUE(u.ok()) << u.status().message;
    unit_ = std::move(u.value());
    ASSERT_TRUE(unit_->start());
  }
  CanPair pair_;
  std::unique_ptr<ChildProcess> emu_;
  std::unique_ptr<SocketCanUnit> unit_;
};

TEST_F(CanEmu, TiltedUnitReadsTheModelOutputWithTheConfiguredNoise) {
  // alpha1 = 30 deg: u = [sin 30, cos 30, 0]; biases on top (model.md J = Delta + u).
  start_emu({"--rate-hz", "400", "--alpha1-deg", "30", "--bias-ug", "100,-200,300",
             "--noise-ug-rthz", "20", "--seed", "7"});
  auto r = unit_->collect(1.0);
  ASSERT_TRUE(r.ok()) << r.status().message;
  const auto& samples = r.value();
  ASSERT_GE(samples.size(), 100U);  // 400 expected; generous for a loaded machine
  const double sigma_sample_g = 20e-6 * std::sqrt(400.0);
  const double expected_g[3] = {std::sin(30 * kDeg) + 100e-6, std::cos(30 * kDeg) - 200e-6, 300e-6};
  for (std::size_t a = 0; a < 3; ++a) {
    const auto s = stats(samples, a);
    const double sigma_mean_g = sigma_sample_g / std::sqrt(static_cast<double>(samples.size()));
    EXPECT_NEAR(s.mean / kStandardGravity_mps2, expected_g[a], 5 * sigma_mean_g) << "axis " << a;
    EXPECT_NEAR(s.sigma / kStandardGravity_mps2, sigma_sample_g, 0.25 * sigma_sample_g)
        << "axis " << a;
  }
  for (std::size_t i = 1; i < samples.size(); ++i)
    ASSERT_EQ(samples[i].counter, samples[i - 1].counter + 1);
  EXPECT_EQ(unit_->health().incomplete_samples, 0U);
}

// The emulator sends with a DBC written by hand for its frames, the driver decodes with
// the built-in layout: the DBC describes the same bits (docs/unit-can.md).
TEST_F(CanEmu, EmulatorOnTheHandWrittenDbcSpeaksTheDefaultLayout) {
  start_emu({"--rate-hz", "200", "--alpha1-deg", "90", "--layout",
             std::string(STANDCAL_CAN_TEST_DATA) + "/standcal_unit.dbc", "--temperature-c",
             "31.5"});
  auto r = unit_->collect(0.5);
  ASSERT_TRUE(r.ok()) << r.status().message;
  ASSERT_GE(r.value().size(), 20U);
  const auto x = stats(r.value(), 0);
  EXPECT_NEAR(x.mean / kStandardGravity_mps2, 1.0, 1e-4);  // alpha1 = +90 deg: x reads +g
  EXPECT_NEAR(r.value().back().temperature_c, 31.5, 0.01);
  EXPECT_EQ(unit_->health().incomplete_samples, 0U);
}

TEST_F(CanEmu, InjectedLossDuplicationAndReorderingShowInTheHealthCounters) {
  start_emu({"--rate-hz", "500", "--alpha2-deg", "90", "--noise-ug-rthz", "5", "--loss", "0.03",
             "--duplicate", "0.03", "--reorder", "0.03", "--seed", "11"});
  auto r = unit_->collect(1.0);
  ASSERT_TRUE(r.ok()) << r.status().message;
  const auto& samples = r.value();
  ASSERT_GE(samples.size(), 50U);
  const auto h = unit_->health();
  EXPECT_GT(h.incomplete_samples, 0U);
  EXPECT_GT(h.duplicate_frames, 0U);
  // Nothing invented: counters strictly increase and every value is the real z = +1 g.
  for (std::size_t i = 1; i < samples.size(); ++i)
    ASSERT_GT(samples[i].counter, samples[i - 1].counter);
  const double sigma_g = 5e-6 * std::sqrt(500.0);
  for (const auto& s : samples)
    ASSERT_NEAR(s.force_mps2[2] / kStandardGravity_mps2, 1.0, 8 * sigma_g);
}

TEST_F(CanEmu, CounterWrapThroughTheEmulator) {
  start_emu({"--rate-hz", "1000", "--counter-start", "65200"});
  auto r = unit_->collect(1.0);
  ASSERT_TRUE(r.ok()) << r.status().message;
  ASSERT_GE(r.value().size(), 100U);
  for (std::size_t i = 1; i < r.value().size(); ++i)
    ASSERT_EQ(r.value()[i].counter, r.value()[i - 1].counter + 1);
  EXPECT_EQ(unit_->health().counter_resyncs, 0U);
  EXPECT_EQ(unit_->health().incomplete_samples, 0U);
}

TEST_F(CanEmu, InjectedSilenceFailsTheSampling) {
  start_emu({"--rate-hz", "200", "--silence-after-s", "0.3"}, {0.4, 4});
  auto r = unit_->collect(20.0);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().kind, ErrorKind::timeout);
  EXPECT_NE(r.status().message.find("no CAN frame from the accelerometer unit on fd"),
            std::string::npos);
  EXPECT_NE(r.status().message.find("for 0.4 s"), std::string::npos);
  EXPECT_TRUE(unit_->health().silent);
}

#ifdef STANDCAL_CLI_PATH
// Runs `standcal unit --fd N read ...` against the emulator; returns exit code and stdout.
std::pair<int, std::string> run_cli_against_emu(std::vector<std::string> emu_flags,
                                                std::vector<std::string> cli_args) {
  CanPair pair;
  std::vector<std::string> emu_argv{STANDCAL_CAN_EMU_PATH, "--fd", std::to_string(pair.bus_fd())};
  emu_argv.insert(emu_argv.end(), emu_flags.begin(), emu_flags.end());
  ChildProcess emu(emu_argv, pair.bus_fd());
  pair.close_bus();
  char out_path[] = "/tmp/standcal-unit-cli-XXXXXX";
  const int out_fd = mkstemp(out_path);
  const int unit_fd = pair.release_unit_fd();
  std::vector<std::string> cli_argv{STANDCAL_CLI_PATH, "unit", "--fd", std::to_string(unit_fd)};
  cli_argv.insert(cli_argv.end(), cli_args.begin(), cli_args.end());
  int code;
  {
    ChildProcess cli(cli_argv, unit_fd, out_fd);
    close(unit_fd);
    code = cli.wait_exit(30);
  }
  close(out_fd);
  std::ifstream in(out_path);
  std::stringstream text;
  text << in.rdbuf();
  unlink(out_path);
  return {code, text.str()};
}

TEST(UnitCli, ReadPrintsPerAxisStatisticsOfTheEmulatedUnit) {
  const auto [code, out] =
      run_cli_against_emu({"--rate-hz", "500", "--alpha1-deg", "90", "--noise-ug-rthz", "10"},
                          {"read", "--seconds", "1"});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("accelerometer unit on fd"), std::string::npos) << out;
  EXPECT_NE(out.find(" 0 incomplete"), std::string::npos) << out;
  EXPECT_NE(out.find("bus error-active"), std::string::npos) << out;
  // alpha1 = +90 deg: x reads +g (model.md hardware sign check).
  double mean_mps2 = 0, sigma_mps2 = 0, mean_g = 0, sigma_ug = 0;
  const auto x_line = out.find("\nx ");
  ASSERT_NE(x_line, std::string::npos) << out;
  ASSERT_EQ(std::sscanf(out.c_str() + x_line + 3, "%lf %lf %lf %lf", &mean_mps2, &sigma_mps2,
                        &mean_g, &sigma_ug),
            4)
      << out;
  EXPECT_NEAR(mean_g, 1.0, 50e-6);
  EXPECT_NEAR(sigma_ug, 10 * std::sqrt(500.0), 0.3 * 10 * std::sqrt(500.0));
}

// A vendor-style DBC (Motorola signals, a status signal and a float the role map leaves
// out) read by `standcal unit --layout`, against the emulator sending the documented JSON
// layout of the same frames.
TEST(UnitCli, ReadsAVendorDbcThroughARoleMap) {
  const std::string data = STANDCAL_CAN_TEST_DATA;
  const auto [code, out] = run_cli_against_emu(
      {"--rate-hz", "200", "--alpha1-deg", "90", "--layout", data + "/vendor_imu_signals.json"},
      {"--layout", data + "/vendor_imu_layout.json", "read", "--seconds", "0.5"});
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find(" 0 incomplete"), std::string::npos) << out;
  double mean_mps2 = 0, sigma_mps2 = 0, mean_g = 0;
  const auto x_line = out.find("\nx ");
  ASSERT_NE(x_line, std::string::npos) << out;
  ASSERT_EQ(std::sscanf(out.c_str() + x_line + 3, "%lf %lf %lf", &mean_mps2, &sigma_mps2, &mean_g),
            3)
      << out;
  EXPECT_NEAR(mean_g, 1.0, 1e-4);
}

TEST(UnitCli, ASilentUnitExitsNonZero) {
  const auto [code, out] = run_cli_against_emu({"--silence-after-s", "0"},
                                               {"--silence-s", "0.3", "read", "--seconds", "2"});
  EXPECT_EQ(code, 1);
  EXPECT_EQ(out, "");  // the reason goes to stderr, one line
}
#endif

}  // namespace
}  // namespace standcal::drivers::can
