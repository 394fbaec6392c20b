// The input reader (raw_input.hpp): formats told from the content, units from names or
// values, and errors that name file, line and column.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "calib/raw_input.hpp"
#include "calib/static_intervals.hpp"
#include "tests/calib/test_support.hpp"

namespace standcal {
namespace {

using test::kXsens;

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The first `n` lines of the Xsens file, as the file has them.
std::string xsens_head(int n) {
  const std::string all = file_text(kXsens);
  std::size_t end = 0;
  for (int i = 0; i < n; ++i) end = all.find('\n', end) + 1;
  return all.substr(0, end);
}

// The error message of parsing `text`, or "" when it parses.
std::string input_error_of(const std::string& text, const InputOptions& options = {},
                           const std::string& source = "in.csv") {
  try {
    parse_input(text, source, options);
  } catch (const RecordingError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A standcal-recording/1 file with angle columns (recording_test.cpp's example).
const std::string kStandcalHeader =
    "# format: standcal-recording/1\n"
    "# g_local_mps2: 9.81625\n"
    "# settle_s: 5\n"
    "# sample_rate_hz: 100\n";
const std::string kStandcalColumns =
    "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,alpha1_deg,alpha2_deg,fx_mps2,fy_mps2,fz_mps2,temp_c\n";
const std::string kStandcalRows =
    "5.000,0,0.0000,0.0000,0.000012,-0.000210,0.000421,9.816702,-0.000217,23.05\n"
    "5.010,0,0.0000,0.0000,0.000012,-0.000210,0.000425,9.816700,-0.000219,23.05\n"
    "20.000,1,90.0000,0.0000,,,9.816702,0.000421,-0.000217,\n";

// Rows in g at 100 Hz: t, x, y, z.
const std::string kRowsG =
    "0.00,0.012,-0.004,0.998\n"
    "0.01,0.011,-0.003,0.999\n"
    "0.02,0.013,-0.005,0.997\n";

TEST(RawInputImuTk, ReadsTheVendoredXsensFile) {
  const RawInput in = read_input(kXsens);
  EXPECT_EQ(in.format, InputFormat::imu_tk);
  EXPECT_EQ(in.units, InputUnits::counts);
  EXPECT_TRUE(contains(in.units_how, "integer")) << in.units_how;
  ASSERT_EQ(in.size(), 51175u);
  EXPECT_NEAR(in.sample_rate_hz, 100.0, 0.5);
  EXPECT_DOUBLE_EQ(in.t_s.front(), 0.02984);
  EXPECT_DOUBLE_EQ(in.t_s.back(), 511.718);
  EXPECT_EQ(in.sample(0), Vec3(33108, 33329, 36429));
  EXPECT_EQ(in.sample(in.size() - 1), Vec3(35290, 35137, 27631));
  EXPECT_TRUE(in.ignored_columns.empty());
  EXPECT_TRUE(in.block.empty());
  EXPECT_FALSE(in.recording.has_value());
  EXPECT_FALSE(in.g_given);
  EXPECT_DOUBLE_EQ(in.g_mps2, kStandardGravity_mps2);
  ASSERT_EQ(in.warnings.size(), 1u);  // g assumed
  EXPECT_TRUE(contains(in.warnings[0], "9.80665"));
}

TEST(RawInputImuTk, TheSameRowsUnderACommaHeaderReadTheSame) {
  const std::string head = xsens_head(300);
  const RawInput plain = parse_input(head, "head.mat");
  std::istringstream lines(head);
  std::string csv = "t,x,y,z\n";
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    std::string f;
    bool first = true;
    while (fields >> f) {
      if (!first) csv += ',';
      csv += f;
      first = false;
    }
    csv += '\n';
  }
  const RawInput in = parse_input(csv, "head.csv");
  EXPECT_EQ(plain.format, InputFormat::imu_tk);
  EXPECT_EQ(in.format, InputFormat::delimited);
  EXPECT_EQ(in.units, InputUnits::counts);
  ASSERT_EQ(in.size(), 300u);
  EXPECT_EQ(in.t_s, plain.t_s);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(in.axis[k], plain.axis[k]);
  EXPECT_DOUBLE_EQ(in.sample_rate_hz, plain.sample_rate_hz);
}

// A corrupted value was read as a sample and overflowed the noise analysis (`standcal
// noise`: an Allan deviation of infinity; the raw_input fuzz target, 2026-12-04).
TEST(RawInputErrors, AValueNoAccelerometerGivesNamesLineAndColumn) {
  const std::string samples = input_error_of("t,ax,ay,az\n0,0,0,1\n1,-7.36E161,0,1\n");
  EXPECT_TRUE(contains(samples,
                       "in.csv:3: column 2: column 'ax': -7.36e+161 is beyond any "
                       "accelerometer's output"))
      << samples;
  InputOptions means;
  means.format = InputFormat::means;
  const std::string table =
      input_error_of("mean_x,mean_y,mean_z\n0,0,1\n0,2e12,0\n", means, "means.csv");
  EXPECT_TRUE(contains(table, "means.csv:3: column 2: column 'mean_y': 2e+12 is beyond")) << table;
  EXPECT_EQ(input_error_of("t ax ay az\n0 0 0 -1e12\n1 0 0 1e12\n"), "");
  // A standard error is in the same units: 1e300 squared overflowed the fit's weights, which
  // then said "position 0 has a mean or standard error that is not a finite number".
  const std::string se = input_error_of(
      "mean_x,mean_y,mean_z,se_x,se_y,se_z\n0.01,0.02,0.98,1e-5,1e-5,1e-5\n"
      "0.01,0.99,0.02,1e-5,1e300,1e-5\n",
      means, "means.csv");
  EXPECT_TRUE(contains(se, "means.csv:3: column 5: column 'se_y': 1e+300 is beyond")) << se;
}

// A means table's sample count of 4e89 overflowed the interval's integer count in the norm fit
// (UBSan: "outside the range of representable values of type 'unsigned long'"; the raw_input
// fuzz target, 2026-12-05): a count beyond 1e12 is refused at its line and column.
TEST(RawInputErrors, ASampleCountNoMeanHoldsNamesLineAndColumn) {
  InputOptions means;
  means.format = InputFormat::means;
  const std::string header = "mean_x,mean_y,mean_z,n\n0.01,0.02,0.98,400\n";
  const std::string huge = input_error_of(header + "0.01,0.99,0.02,4e89\n", means, "means.csv");
  EXPECT_TRUE(contains(huge,
                       "means.csv:3: column 4: column 'n': the sample count must be "
                       "positive and at most 1e12, not 4e+89"))
      << huge;
  EXPECT_EQ(input_error_of(header + "0.01,0.99,0.02,1e12\n", means, "means.csv"), "");
}

// Two times of +-1.7e308 s differ by infinity, and the rate read from the steps was 0 Hz (a
// review of the raw_input fuzz target's property, 2026-12-04).
TEST(RawInputErrors, ATimeNoRecordingHoldsNamesLineAndColumn) {
  const std::string message =
      input_error_of("t,ax,ay,az\n-1.7e308,0.01,0.02,0.98\n1.7e308,0.01,0.02,0.99\n");
  EXPECT_TRUE(contains(message,
                       "in.csv:2: column 1: column 't': -1.7e+308 s is not a time a "
                       "recording holds (within +-1e12 s)"))
      << message;
  // After the column's unit: 2e15 microseconds are 2e9 s, a time since 1970.
  EXPECT_EQ(input_error_of("t_us,ax,ay,az\n2e15,0.01,0.02,0.98\n2.00000001e15,0.01,0.02,0.99\n"),
            "");
}

// A header rate of 1e300 Hz was taken over the rows' times (a sample period of 1e-300 s) in a
// standcal recording without angle columns, as the stand recordings' reader had taken it; one
// of 1e-300 Hz, or --rate-hz as slow, made rows without a time column times of 1e300 s.
TEST(RawInputErrors, ARateNoRecordingHoldsNamesWhereItWasGiven) {
  const std::string rows = "t_s,pos,fx_mps2,fy_mps2,fz_mps2\n0,0,0,0,9.8\n0.01,0,0,0,9.8\n";
  const std::string fast =
      input_error_of("# format: standcal-recording/1\n# sample_rate_hz: 1e300\n" + rows);
  EXPECT_TRUE(contains(fast,
                       "in.csv:2: header 'sample_rate_hz': 1e300 Hz is not a sample rate "
                       "(at least 1e-12, at most 1e6 Hz)"))
      << fast;
  const std::string untimed = "ax,ay,az\n0.01,0.02,0.98\n0.01,0.02,0.99\n0.01,0.02,0.97\n";
  const std::string slow = input_error_of("# sample_rate_hz: 1.5e-12\n" + untimed);
  EXPECT_TRUE(contains(slow,
                       "in.csv:1: header 'sample_rate_hz': 1.5e-12 Hz gives the last of 3 "
                       "rows the time 1.33333e+12 s, beyond 1e12 s"))
      << slow;
  InputOptions options;
  options.rate_hz = 1.5e-12;
  try {
    parse_input(untimed, "in.csv", options);
    ADD_FAILURE() << "--rate-hz 1.5e-12 was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "--rate-hz: 1.5e-12 Hz gives the last of 3 rows the time"))
        << e.what();
  }
  // Slower than one sample in 1e12 s is no rate, with or without a time column: a rate of
  // 1e-320 Hz gave a sample period of infinity (a subnormal's reciprocal).
  const std::string timed = "t,ax,ay,az\n0,0.01,0.02,0.98\n1,0.01,0.02,0.99\n";
  for (const std::string& body : {untimed, timed}) {
    const std::string tiny = input_error_of("# sample_rate_hz: 1e-320\n" + body);
    EXPECT_TRUE(contains(tiny,
                         "in.csv:1: header 'sample_rate_hz': 1e-320 Hz is not a sample rate (at "
                         "least 1e-12, at most 1e6 Hz)"))
        << tiny;
    options.rate_hz = 1e-300;
    try {
      parse_input(body, "in.csv", options);
      ADD_FAILURE() << "--rate-hz 1e-300 was taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_TRUE(contains(e.what(), "--rate-hz: 1e-300 Hz is not a sample rate")) << e.what();
    }
  }
  options.rate_hz = 2e6;
  EXPECT_THROW(parse_input(untimed, "in.csv", options), std::invalid_argument);
  options.rate_hz = 1e-9;  // a slow rate whose times stay within the bound is a rate
  EXPECT_DOUBLE_EQ(parse_input(untimed, "in.csv", options).t_s[2], 2e9);
}

// `said` is among the reader's warnings exactly once.
void expect_warned_once(const RawInput& in, const std::string& said) {
  EXPECT_EQ(std::count(in.warnings.begin(), in.warnings.end(), said), 1)
      << testing::PrintToString(in.warnings);
}

// The readers of other tools' files say it too when --g-mps2 replaces their header's g
// (the stand recordings' readers: StreamingReader.AGravityGivenBesideTheHeadersReplacesIt...).
TEST(RawInputGravity, AGravityGivenOverAHeadersIsUsedAndSaidSo) {
  const std::string untimed =
      "# g_local_mps2: 9.81\n# sample_rate_hz: 25\nax,ay,az\n0.01,0.02,0.98\n0.01,0.02,0.99\n";
  InputOptions given;
  given.g_mps2 = 9.8;
  const RawInput replaced = parse_input(untimed, "in.csv", given);
  EXPECT_EQ(replaced.g_mps2, 9.8);
  const std::string said =
      "in.csv: --g-mps2 9.8 replaces the header's g_local_mps2 9.81 (-1019.4 ppm): the scale "
      "factors take up the difference";
  expect_warned_once(replaced, said);
  given.g_mps2 = 9.81;  // the header's own g: nothing said
  EXPECT_EQ(parse_input(untimed, "in.csv", given).warnings,
            parse_input(untimed, "in.csv", InputOptions{}).warnings);
}

// Rows without a time column take their times from --rate-hz over the header's rate (a
// header that misstates it is mended so), and the operator is told: the option replaced the
// header's rate without a word, and every time constant the fits estimate follows it.
TEST(RawInputRate, ARateGivenOverAnUntimedFilesHeaderIsUsedAndSaidSo) {
  const std::string untimed =
      "# sample_rate_hz: 25\nax,ay,az\n0.01,0.02,0.98\n0.01,0.02,0.99\n0.01,0.02,0.97\n";
  InputOptions given;
  given.rate_hz = 100;
  const RawInput replaced = parse_input(untimed, "in.csv", given);
  EXPECT_EQ(replaced.sample_rate_hz, 100);
  EXPECT_DOUBLE_EQ(replaced.t_s.back(), 0.02);
  const std::string said =
      "in.csv:1: --rate-hz 100 replaces the header's sample_rate_hz 25: the rows have no time "
      "column, so their times are made from 100 Hz";
  expect_warned_once(replaced, said);
  given.rate_hz = 25;  // the header's own rate: nothing replaced, nothing said
  const RawInput same = parse_input(untimed, "in.csv", given);
  EXPECT_DOUBLE_EQ(same.t_s.back(), 0.08);
  EXPECT_EQ(same.warnings, parse_input(untimed, "in.csv", InputOptions{}).warnings);
}

// Times 1e-300 s apart made a rate of 1e300 Hz from the steps, and the static detector a
// window of 9223372036854775809 samples (`standcal noise` said so): a float-to-integer
// overflow. Steps faster than 1e6 a second leave the rate unknown, as a zero step does.
TEST(RawInputErrors, TimeStepsFasterThanAnyUnitLeaveTheRateUnknown) {
  std::string text = "t,ax,ay,az\n";
  for (int i = 0; i < 400; ++i)
    text += std::to_string(i) + "e-300," + (i % 2 ? "0.01" : "0.011") + ",0.02,0.98\n";
  const RawInput in = parse_input(text, "tiny.csv");
  EXPECT_TRUE(std::isnan(in.sample_rate_hz)) << in.sample_rate_hz;
  ASSERT_FALSE(in.warnings.empty());
  EXPECT_TRUE(contains(in.warnings.back(),
                       "tiny.csv: the median time step is 1e-300 s, more than 1e6 samples a "
                       "second: no sample period (are the times in another unit?); sample rate "
                       "unknown"))
      << in.warnings.back();
  // 1 MHz itself, its times written to the microsecond: a rate (1000000.0025 Hz from the steps).
  std::string mhz = "t_us,ax,ay,az\n";
  for (int i = 0; i < 400; ++i)
    mhz += std::to_string(1000000000 + i) + "," + (i % 2 ? "0.01" : "0.011") + ",0.02,0.98\n";
  EXPECT_NEAR(parse_input(mhz, "mhz.csv").sample_rate_hz, 1e6, 0.01);
  RawInput fast = in;
  fast.sample_rate_hz = 1e300;  // from a caller that did not read it through the readers
  try {
    (void)detect_static_intervals(fast);
    ADD_FAILURE() << "a rate of 1e300 Hz was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(contains(e.what(),
                         "tiny.csv: 1e+300 Hz is not a sample rate (at least 1e-12, "
                         "at most 1e6 Hz)"))
        << e.what();
  }
  fast.sample_rate_hz = 1e-13;  // it said "above 1e6 Hz" of a rate below the slowest too
  try {
    (void)detect_static_intervals(fast);
    ADD_FAILURE() << "a rate of 1e-13 Hz was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(contains(e.what(), "tiny.csv: 1e-13 Hz is not a sample rate")) << e.what();
  }
}

TEST(RawInputImuTk, ThreeColumnsNeedTheRateAndUseIt) {
  const std::string rows = "0.012 -0.004 0.998\n0.011 -0.003 0.999\n0.013 -0.005 0.997\n";
  const std::string message = input_error_of(rows);
  EXPECT_TRUE(contains(message, "in.csv:1")) << message;
  EXPECT_TRUE(contains(message, "--rate-hz")) << message;
  InputOptions options;
  options.rate_hz = 50;
  const RawInput in = parse_input(rows, "in.txt", options);
  ASSERT_EQ(in.size(), 3u);
  EXPECT_DOUBLE_EQ(in.t_s[2], 0.04);
  EXPECT_DOUBLE_EQ(in.sample_rate_hz, 50);
  EXPECT_EQ(in.units, InputUnits::g);
  EXPECT_DOUBLE_EQ(in.axis[2][1], 0.999);
}

// A file read beside another (the unit's static recording beside a run) has its own options:
// the messages name them as the command line does (InputOptions::option_prefix).
TEST(RawInputImuTk, TheMessagesNameTheOptionsAsTheCommandLineDoes) {
  InputOptions beside;
  beside.option_prefix = "unit-static-";
  const std::string rows = "0.012 -0.004 0.998\n0.011 -0.003 0.999\n";
  const std::string message = input_error_of(rows, beside);
  EXPECT_TRUE(contains(message, "pass --unit-static-rate-hz with the sample rate")) << message;
  beside.columns = {"1", "2", "7"};
  beside.rate_hz = 50;
  const std::string column = input_error_of(rows, beside);
  EXPECT_TRUE(contains(column, "--unit-static-columns: column 7 is out of range")) << column;
  beside.columns.clear();
  const RawInput in = parse_input(rows, "in.txt", beside);
  EXPECT_EQ(in.option("skip-lines"), "--unit-static-skip-lines");
  // A configuration section names its keys (standcald's unit.static_recording_input).
  EXPECT_EQ(input_option_name("unit.static_recording_input.", "rate-hz"),
            "unit.static_recording_input.rate_hz");
}

TEST(RawInputImuTk, ManyColumnsWithoutAHeaderAskForOneOrForColumns) {
  const std::string rows = "0.00 1 2 0.01 0.02 0.98\n0.01 1 2 0.01 0.02 0.99\n";
  const std::string message = input_error_of(rows);
  EXPECT_TRUE(contains(message, "header line")) << message;
  EXPECT_TRUE(contains(message, "--columns")) << message;
  InputOptions options;
  options.columns = {"4", "5", "6"};
  const RawInput in = parse_input(rows, "in.txt", options);
  EXPECT_EQ(in.sample(1), Vec3(0.01, 0.02, 0.99));
  EXPECT_DOUBLE_EQ(in.t_s[1], 0.01);  // column 1 never decreases: the time
  EXPECT_EQ(in.ignored_columns, (std::vector<std::string>{"column 2", "column 3"}));
}

TEST(RawInputDelimited, SemicolonFileWithValuesInG) {
  std::string text = "time;acc_x;acc_y;acc_z\n" + kRowsG;
  for (char& c : text)
    if (c == ',') c = ';';
  const RawInput in = parse_input(text, "semi.csv");
  EXPECT_EQ(in.format, InputFormat::delimited);
  EXPECT_EQ(in.units, InputUnits::g);
  EXPECT_TRUE(contains(in.units_how, "values")) << in.units_how;
  ASSERT_EQ(in.size(), 3u);
  EXPECT_EQ(in.sample(2), Vec3(0.013, -0.005, 0.997));
  EXPECT_NEAR(in.sample_rate_hz, 100, 1e-9);
}

TEST(RawInputDelimited, TabFileWithUnitsInBrackets) {
  const std::string text =
      "timestamp\tAcc X [m/s^2]\tAcc Y [m/s^2]\tAcc Z [m/s^2]\n"
      "0.000\t0.1\t0.2\t9.80\n"
      "0.005\t0.1\t0.2\t9.81\n";
  const RawInput in = parse_input(text, "tab.tsv");
  EXPECT_EQ(in.units, InputUnits::mps2);
  EXPECT_TRUE(contains(in.units_how, "column names")) << in.units_how;
  EXPECT_EQ(in.sample(1), Vec3(0.1, 0.2, 9.81));
  EXPECT_NEAR(in.sample_rate_hz, 200, 1e-9);
}

TEST(RawInputDelimited, GyroscopeAndOtherColumnsAreIgnoredAndListed) {
  const std::string text =
      "t,gx,gy,gz,ax,ay,az,temp,counter\n"
      "0.00,0.1,0.2,0.3,0.012,-0.004,0.998,25.1,1\n"
      "0.01,0.1,0.2,0.3,0.011,-0.003,0.999,25.1,2\n";
  const RawInput in = parse_input(text, "imu.csv");
  EXPECT_EQ(in.sample(0), Vec3(0.012, -0.004, 0.998));
  EXPECT_EQ(in.ignored_columns, (std::vector<std::string>{"gx", "gy", "gz", "temp", "counter"}));
}

TEST(RawInputDelimited, ColumnsByNameAndByNumber) {
  const std::string text =
      "time,a1,a2,a3,b1,b2,b3\n"
      "0.00,5,6,7,0.01,0.02,0.98\n"
      "0.01,5,6,7,0.01,0.02,0.99\n";
  const std::string message = input_error_of(text);
  EXPECT_TRUE(contains(message, "in.csv:1: no accelerometer columns")) << message;
  EXPECT_TRUE(contains(message, "time, a1, a2, a3, b1, b2, b3")) << message;
  EXPECT_TRUE(contains(message, "--columns")) << message;

  InputOptions by_name;
  by_name.columns = {"b1", "B2", " b3 "};
  const RawInput named = parse_input(text, "in.csv", by_name);
  EXPECT_EQ(named.sample(1), Vec3(0.01, 0.02, 0.99));
  EXPECT_DOUBLE_EQ(named.t_s[1], 0.01);
  EXPECT_EQ(named.ignored_columns, (std::vector<std::string>{"a1", "a2", "a3"}));

  InputOptions by_number;
  by_number.columns = {"5", "6", "7"};
  const RawInput numbered = parse_input(text, "in.csv", by_number);
  EXPECT_EQ(numbered.axis, named.axis);

  by_number.columns = {"5", "6", "9"};
  EXPECT_TRUE(contains(input_error_of(text, by_number), "out of range"));
  by_name.columns = {"b1", "b2", "b4"};
  EXPECT_TRUE(contains(input_error_of(text, by_name), "no column named 'b4'"));
}

TEST(RawInputDelimited, NoTimeColumnNeedsTheRate) {
  const std::string text = "ax,ay,az\n0.01,0.02,0.98\n0.01,0.02,0.99\n";
  const std::string message = input_error_of(text);
  EXPECT_TRUE(contains(message, "in.csv:1: no time column")) << message;
  EXPECT_TRUE(contains(message, "--rate-hz")) << message;
  InputOptions options;
  options.rate_hz = 10;
  const RawInput in = parse_input(text, "in.csv", options);
  EXPECT_DOUBLE_EQ(in.t_s[1], 0.1);
  EXPECT_DOUBLE_EQ(in.sample_rate_hz, 10);
}

TEST(RawInputDelimited, MillisecondTimesAreSeconds) {
  const std::string text = "t_ms,ax_g,ay_g,az_g\n0,0,0,1\n20,0,0,1\n40,0,0,1\n";
  const RawInput in = parse_input(text, "ms.csv");
  EXPECT_DOUBLE_EQ(in.t_s[2], 0.04);
  EXPECT_NEAR(in.sample_rate_hz, 50, 1e-9);
  EXPECT_EQ(in.units, InputUnits::g);  // from the names: the values alone could not tell
}

TEST(RawInputDelimited, SkipLinesPassesOverAPreambleAndKeepsLineNumbers) {
  const std::string preamble = "Logger v1.2, serial 1234\nexported 2024-05-01\n";
  const std::string text = preamble + "t,ax,ay,az\n" + kRowsG;
  InputOptions options;
  options.skip_lines = 2;
  const RawInput in = parse_input(text, "log.csv", options);
  ASSERT_EQ(in.size(), 3u);
  EXPECT_EQ(in.sample(0), Vec3(0.012, -0.004, 0.998));
  const std::string bad = preamble + "t,ax,ay,az\n0.00,0.01,0.02,0.98\n0.01,0.01,x,0.98\n";
  EXPECT_TRUE(contains(input_error_of(bad, options), "in.csv:5: column 3"))
      << input_error_of(bad, options);
}

TEST(RawInputDelimited, GravityFromACommentHeaderOrTheOption) {
  const std::string text = "# g_local_mps2: 9.8162\n# exported by logger\nt,ax,ay,az\n" + kRowsG;
  const RawInput in = parse_input(text, "g.csv");
  EXPECT_DOUBLE_EQ(in.g_mps2, 9.8162);
  EXPECT_TRUE(in.g_given);
  EXPECT_TRUE(in.warnings.empty());
  InputOptions options;
  options.g_mps2 = 9.80;
  EXPECT_DOUBLE_EQ(parse_input(text, "g.csv", options).g_mps2, 9.80);
}

TEST(RawInputDelimited, ByteOrderMarkAndCrlfAreAccepted) {
  std::string text = "\xEF\xBB\xBFt,ax,ay,az\r\n";
  std::istringstream rows(kRowsG);
  std::string row;
  while (std::getline(rows, row)) text += row + "\r\n";
  const RawInput in = parse_input(text, "win.csv");
  ASSERT_EQ(in.size(), 3u);
  EXPECT_DOUBLE_EQ(in.axis[2][2], 0.997);
}

TEST(RawInputDelimited, TruncatedLastLineIsDroppedWithAWarning) {
  const RawInput in = parse_input("t,ax,ay,az\n" + kRowsG + "0.03,0.01", "cut.csv");
  EXPECT_EQ(in.size(), 3u);
  ASSERT_FALSE(in.warnings.empty());
  EXPECT_TRUE(contains(in.warnings[0], "cut.csv:5")) << in.warnings[0];
  EXPECT_TRUE(contains(in.warnings[0], "dropped"));
}

TEST(RawInputStandcal, RecordingWithAngleColumnsKeepsTheRecording) {
  const RawInput in = parse_input(kStandcalHeader + kStandcalColumns + kStandcalRows, "rec.csv");
  EXPECT_EQ(in.format, InputFormat::standcal);
  ASSERT_TRUE(in.recording.has_value());
  EXPECT_EQ(in.recording->samples.size(), 3u);
  ASSERT_EQ(in.size(), 3u);
  EXPECT_EQ(in.units, InputUnits::mps2);
  EXPECT_DOUBLE_EQ(in.axis[1][0], 9.816702);
  EXPECT_DOUBLE_EQ(in.t_s[2], 20.0);
  EXPECT_EQ(in.block, (std::vector<int>{0, 0, 1}));
  EXPECT_DOUBLE_EQ(in.g_mps2, 9.81625);
  EXPECT_TRUE(in.g_given);
  EXPECT_DOUBLE_EQ(in.sample_rate_hz, 100);
}

TEST(RawInputStandcal, SkippedPreambleKeepsTheRecordingsLineNumbers) {
  InputOptions options;
  options.skip_lines = 1;
  const std::string bad = "5.020,0,0,0,,,0.1,9.8x,0.1,\n";
  const std::string message =
      input_error_of("exported\n" + kStandcalHeader + kStandcalColumns + bad, options, "rec.csv");
  EXPECT_TRUE(contains(message, "rec.csv:7: column 8")) << message;
}

TEST(RawInputStandcal, RecordingWithoutAngleColumns) {
  const std::string text =
      "# format: standcal-recording/1\n"
      "# g_local_mps2: 9.81\n"
      "# sample_rate_hz: 200\n"
      "t_s,pos,fx_mps2,fy_mps2,fz_mps2,gx\n"
      "0.000,0,0.01,9.81,0.02,0.5\n"
      "0.005,0,0.01,9.80,0.02,0.5\n"
      "3.000,1,9.81,0.01,0.02,0.5\n";
  const RawInput in = parse_input(text, "noangles.csv");
  EXPECT_EQ(in.format, InputFormat::standcal);
  EXPECT_FALSE(in.recording.has_value());
  ASSERT_EQ(in.size(), 3u);
  EXPECT_EQ(in.block, (std::vector<int>{0, 0, 1}));
  EXPECT_EQ(in.sample(2), Vec3(9.81, 0.01, 0.02));
  EXPECT_EQ(in.units, InputUnits::mps2);
  EXPECT_DOUBLE_EQ(in.g_mps2, 9.81);
  EXPECT_TRUE(in.g_given);
  EXPECT_DOUBLE_EQ(in.sample_rate_hz, 200);
  EXPECT_EQ(in.ignored_columns, (std::vector<std::string>{"gx"}));

  const std::string missing = "# format: standcal-recording/1\nt_s,fx_mps2,fz_mps2\n0,1,2\n";
  EXPECT_TRUE(contains(input_error_of(missing), "in.csv:2: required column 'fy_mps2' is missing"));
}

// A standcal file without angle columns keeps its header's warm-up where a pos column says
// which rows are position 1's (the front of block 0: the curves' alone); without one it is
// said not to be used. It had been read past: the unit's settling went into block 0.
TEST(RawInputStandcal, AWarmUpWithoutAngleColumnsIsTheFrontOfBlockZero) {
  const std::string head = "# format: standcal-recording/1\n# g_local_mps2: 9.81\n";
  const std::string rows =
      "0.000,0,0.01,9.81,0.02\n"
      "0.005,0,0.01,9.80,0.02\n"
      "3.000,1,9.81,0.01,0.02\n";
  const RawInput in =
      parse_input(head + "# warmup_s: 0.004\nt_s,pos,fx_mps2,fy_mps2,fz_mps2\n" + rows, "w.csv");
  EXPECT_DOUBLE_EQ(in.warmup_s, 0.004);
  EXPECT_TRUE(in.warnings.empty());
  // Its rows are no static interval: the first 0.5 s of 4 s in block 0, then block 1.
  std::string held =
      head + "# sample_rate_hz: 100\n# warmup_s: 0.5\nt_s,pos,fx_mps2,fy_mps2,fz_mps2\n";
  for (int i = 0; i < 800; ++i) {
    char row[96];
    const bool turned = i >= 400;
    std::snprintf(row, sizeof row, "%.2f,%d,%.6f,%.6f,0.02\n", i / 100.0 + (turned ? 3 : 0),
                  turned ? 1 : 0, (turned ? 9.81 : 0.01) + 1e-4 * (i % 3),
                  (turned ? 0.01 : 9.81) - 1e-4 * (i % 2));
    held += row;
  }
  const StaticDetection d = detect_static_intervals(parse_input(held, "held.csv"));
  EXPECT_EQ(d.warm_up, (std::pair<std::size_t, std::size_t>{0, 50}));
  ASSERT_EQ(d.intervals.size(), 2u);
  EXPECT_EQ(d.intervals[0].begin, 50u);

  std::string no_pos = head + "# warmup_s: 0.004\nt_s,fx_mps2,fy_mps2,fz_mps2\n";
  for (const char* r : {"0.000,0.01,9.81,0.02\n", "0.005,0.01,9.80,0.02\n"}) no_pos += r;
  const RawInput without = parse_input(no_pos, "w.csv");
  EXPECT_DOUBLE_EQ(without.warmup_s, 0);
  ASSERT_EQ(without.warnings.size(), 1u);
  EXPECT_TRUE(contains(without.warnings[0], "w.csv:3: header warmup_s 0.004 s is not used"))
      << without.warnings[0];

  const std::string bad = head + "# warmup_s: -1\nt_s,pos,fx_mps2,fy_mps2,fz_mps2\n" + rows;
  EXPECT_TRUE(contains(input_error_of(bad), "in.csv:3: header 'warmup_s': -1 s is not a warm-up"))
      << input_error_of(bad);
}

TEST(RawInputMeans, TableWithCountsAndStandardErrors) {
  const std::string text =
      "mean_x,mean_y,mean_z,n,se_x,se_y,se_z,std_x\n"
      "0.0012,-0.0004,1.0003,500,1e-5,2e-5,3e-5,0.0002\n"
      "1.0011,0.0003,0.0002,400,1e-5,1e-5,1e-5,0.0002\n";
  InputOptions options;
  options.format = InputFormat::means;
  const RawInput in = parse_input(text, "means.csv", options);
  EXPECT_EQ(in.format, InputFormat::means);
  EXPECT_EQ(in.size(), 0u);
  ASSERT_EQ(in.means.size(), 2u);
  EXPECT_EQ(in.means[0].line, 2);
  EXPECT_EQ(in.means[1].mean, Vec3(1.0011, 0.0003, 0.0002));
  ASSERT_TRUE(in.means[0].samples.has_value());
  EXPECT_DOUBLE_EQ(*in.means[0].samples, 500);
  ASSERT_TRUE(in.means[0].standard_error.has_value());
  EXPECT_EQ(*in.means[0].standard_error, Vec3(1e-5, 2e-5, 3e-5));
  EXPECT_EQ(in.units, InputUnits::g);
  EXPECT_EQ(in.ignored_columns, (std::vector<std::string>{"std_x"}));
}

TEST(RawInputMeans, MissingMeanColumnOrFieldIsNamed) {
  InputOptions options;
  options.format = InputFormat::means;
  const std::string message = input_error_of("mean_x,mean_y,n\n0.1,0.2,10\n", options);
  EXPECT_TRUE(contains(message, "in.csv:1: no mean column for z")) << message;
  const std::string empty_field =
      input_error_of("mean_x,mean_y,mean_z\n0.01,0.02,0.99\n0.01,,0.99\n", options);
  EXPECT_TRUE(contains(empty_field, "in.csv:3: column 2: column 'mean_y': empty field"))
      << empty_field;
  const std::string not_number = input_error_of("x;y;z\n0.01;0.02;0.99\n0.01;0.02;zero\n", options);
  EXPECT_TRUE(contains(not_number, "in.csv:3: column 3")) << not_number;
}

TEST(RawInputUnits, FromColumnNames) {
  EXPECT_EQ(parse_input("t,fx_mps2,fy_mps2,fz_mps2\n0,0,0,10\n1,0,0,10\n", "a").units,
            InputUnits::mps2);
  EXPECT_EQ(parse_input("t,acc_x_raw,acc_y_raw,acc_z_raw\n0,0,0,10\n1,0,0,10\n", "b").units,
            InputUnits::counts);
  EXPECT_EQ(parse_input("t,Accel X (g),Accel Y (g),Accel Z (g)\n0,0,0,10\n1,0,0,10\n", "c").units,
            InputUnits::g);
  EXPECT_TRUE(
      contains(input_error_of("t,ax_g,ay_g,az_mps2\n0,0,0,1\n1,0,0,1\n"), "different units"));
}

TEST(RawInputUnits, FromValues) {
  const RawInput g = parse_input("t,ax,ay,az\n" + kRowsG, "g.csv");
  EXPECT_EQ(g.units, InputUnits::g);
  const RawInput mps2 = parse_input("t,ax,ay,az\n0,0.1,0.2,9.79\n0.01,0.1,0.2,9.81\n", "m.csv");
  EXPECT_EQ(mps2.units, InputUnits::mps2);
  const RawInput counts =
      parse_input("t,ax,ay,az\n0,1000,-20,16384\n0.01,1002,-21,16390\n", "c.csv");
  EXPECT_EQ(counts.units, InputUnits::counts);
  EXPECT_TRUE(contains(counts.units_how, "16"));  // the median norm it saw
}

TEST(RawInputUnits, SmallIntegersCannotBeToldAndAskForUnits) {
  const std::string text = "t x y z\n0 0 0 1\n1 1 0 0\n2 0 1 0\n";
  const std::string message = input_error_of(text, {}, "ints.txt");
  EXPECT_TRUE(contains(message, "cannot tell the units of ints.txt")) << message;
  EXPECT_TRUE(contains(message, "pass --units counts|g|mps2")) << message;
  InputOptions options;
  options.units = InputUnits::g;
  const RawInput in = parse_input(text, "ints.txt", options);
  EXPECT_EQ(in.units, InputUnits::g);
  EXPECT_EQ(in.units_how, "--units g");
}

TEST(RawInputErrors, NonNumberNamesLineAndColumn) {
  const std::string message = input_error_of("t,ax,ay,az\n0,0.1,0.2,0.98\n0.01,0.1,abc,0.98\n");
  EXPECT_TRUE(contains(message, "in.csv:3: column 3: column 'ay': 'abc' is not a number"))
      << message;
  const std::string imu_tk = input_error_of("0.0 1.5 2.5 3.5\n0.1 1.5 2.5 3.5x\n");
  EXPECT_TRUE(contains(imu_tk, "in.csv:2: column 4")) << imu_tk;
}

TEST(RawInputErrors, TimeMustNotDecrease) {
  const std::string message =
      input_error_of("t,ax,ay,az\n0.00,0.1,0.2,0.98\n0.02,0.1,0.2,0.98\n0.01,0.1,0.2,0.98\n");
  EXPECT_TRUE(contains(message, "in.csv:4: column 1: 't' goes backwards")) << message;
}

TEST(RawInputErrors, FileShapeErrors) {
  EXPECT_TRUE(contains(input_error_of(""), "the file is empty"));
  EXPECT_TRUE(contains(input_error_of("\n  \n"), "the file is empty"));
  EXPECT_TRUE(contains(input_error_of("t,ax,ay,az\n"), "in.csv:1: a header line but no data rows"));
  EXPECT_TRUE(contains(input_error_of("t,ax,ay,az\n0,0.1,0.2,0.9\n0,0.1,0.2\n"),
                       "in.csv:3: expected 4 fields as in the header line 1, found 3"));
  const std::string twice = input_error_of("t,x,ax,y,z\n0,0.1,0.1,0.2,0.9\n");
  EXPECT_TRUE(contains(twice, "in.csv:1: column 3: columns 'x' (column 2) and 'ax' (column 3)"))
      << twice;
  InputOptions imu_tk;
  imu_tk.format = InputFormat::imu_tk;
  EXPECT_TRUE(contains(input_error_of("t,ax,ay,az\n" + kRowsG, imu_tk), "in.csv:1: column 1"));
}

// A file is read as a stream (raw_input.cpp's LineFeed: only the lines before the rows are
// kept, to look back over), text in memory at once: the same input either way, or the same
// error, for every format and the awkward files the tests above read.
struct ReadOutcome {
  std::string error;
  RawInput input;
};

ReadOutcome outcome_of(const std::function<RawInput()>& read) {
  ReadOutcome out;
  try {
    out.input = read();
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  return out;
}

bool same_numbers(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])))) return false;
  return true;
}

void expect_same_outcome(const ReadOutcome& file, const ReadOutcome& text) {
  EXPECT_EQ(file.error, text.error);
  const RawInput& a = file.input;
  const RawInput& b = text.input;
  EXPECT_EQ(a.format, b.format);
  EXPECT_EQ(a.units, b.units);
  EXPECT_EQ(a.units_how, b.units_how);
  EXPECT_EQ(a.g_mps2, b.g_mps2);
  EXPECT_EQ(a.g_given, b.g_given);
  EXPECT_TRUE(same_numbers(a.t_s, b.t_s));
  for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(same_numbers(a.axis[k], b.axis[k])) << k;
  EXPECT_TRUE(same_numbers({a.sample_rate_hz}, {b.sample_rate_hz}));
  EXPECT_EQ(a.block, b.block);
  ASSERT_EQ(a.means.size(), b.means.size());
  for (std::size_t i = 0; i < a.means.size(); ++i) {
    EXPECT_EQ(a.means[i].line, b.means[i].line);
    EXPECT_EQ(a.means[i].mean, b.means[i].mean);
    EXPECT_EQ(a.means[i].samples, b.means[i].samples);
    EXPECT_EQ(a.means[i].standard_error, b.means[i].standard_error);
  }
  EXPECT_EQ(a.recording.has_value(), b.recording.has_value());
  if (a.recording && b.recording)
    EXPECT_EQ(a.recording->samples.size(), b.recording->samples.size());
  EXPECT_EQ(a.ignored_columns, b.ignored_columns);
  EXPECT_EQ(a.warnings, b.warnings);
}

TEST(RawInputFile, AFileReadAsAStreamIsReadAsItsTextInMemory) {
  InputOptions none, skip_two, skip_one, means;
  skip_two.skip_lines = 2;
  skip_one.skip_lines = 1;
  means.format = InputFormat::means;
  std::string crlf = "\xEF\xBB\xBFt,ax,ay,az\r\n";
  std::istringstream rows(kRowsG);
  for (std::string row; std::getline(rows, row);) crlf += row + "\r\n";
  std::string long_file = "# exported by logger\nt,ax,ay,az\n";  // rows across 1 MiB blocks
  for (int i = 0; i < 60000; ++i)
    long_file += std::to_string(i * 0.01) + ",0.0123456,-0.0045678,0.9987654\n";
  const std::string preamble = "Logger v1.2, serial 1234\nexported 2024-05-01\n";
  const std::vector<std::tuple<std::string, std::string, InputOptions>> cases{
      {"xsens head", xsens_head(300), none},
      {"delimited, g comment", "# g_local_mps2: 9.8162\n# note\nt,ax,ay,az\n" + kRowsG, none},
      {"preamble", preamble + "t,ax,ay,az\n" + kRowsG, skip_two},
      {"preamble, bad number", preamble + "t,ax,ay,az\n0,0.01,0.02,0.98\n0.01,0.01,x,0.98\n",
       skip_two},
      {"byte order mark, CRLF", crlf, none},
      {"cut-off last line", "t,ax,ay,az\n" + kRowsG + "0.03,0.01", none},
      {"long", long_file, none},
      {"standcal with angles", kStandcalHeader + kStandcalColumns + kStandcalRows, none},
      {"standcal with angles, preamble",
       "exported\n" + kStandcalHeader + kStandcalColumns + "5.020,0,0,0,,,0.1,9.8x,0.1,\n",
       skip_one},
      {"standcal without angles",
       "# format: standcal-recording/1\n# sample_rate_hz: 200\nt_s,pos,fx_mps2,fy_mps2,fz_mps2\n"
       "0.000,0,0.01,9.81,0.02\n0.005,0,0.01,9.80,0.02\n3.000,1,9.81,0.01,0.02\n",
       none},
      {"means", "mean_x,mean_y,mean_z,n\n0.0012,-0.0004,1.0003,500\n1.0011,0.0003,0.0002,400\n",
       means},
      {"empty", "", none},
      {"comments only", "# a\n# b\n", none},
      {"header only", "t,ax,ay,az\n", none},
      {"fields missing", "t,ax,ay,az\n0,0.1,0.2,0.9\n0,0.1,0.2\n", none},
  };
  const std::string dir = ::testing::TempDir();
  for (const auto& one : cases) {
    const std::string& name = std::get<0>(one);
    const std::string& text = std::get<1>(one);
    const InputOptions& options = std::get<2>(one);
    SCOPED_TRACE(name);
    const std::string path = dir + "/raw_input_stream.csv";
    std::ofstream(path, std::ios::binary) << text;
    const ReadOutcome from_file = outcome_of([&] { return read_input(path, options); });
    const ReadOutcome from_text = outcome_of([&] { return parse_input(text, path, options); });
    expect_same_outcome(from_file, from_text);
    if (name == "long") EXPECT_EQ(from_file.input.size(), 60000u);
  }
}

TEST(RawInputNames, SpellingsRoundTripAndUnknownOnesAreRefused) {
  for (InputFormat f : {InputFormat::automatic, InputFormat::standcal, InputFormat::imu_tk,
                        InputFormat::delimited, InputFormat::means})
    EXPECT_EQ(parse_input_format(to_string(f)), f);
  for (InputUnits u : {InputUnits::automatic, InputUnits::counts, InputUnits::g, InputUnits::mps2})
    EXPECT_EQ(parse_input_units(to_string(u)), u);
  EXPECT_THROW(parse_input_format("csv"), std::invalid_argument);
  EXPECT_THROW(parse_input_units("mg"), std::invalid_argument);
  EXPECT_THROW(read_input("/nonexistent/raw_input_test.csv"), std::runtime_error);
}

TEST(RawInputMeans, ATableOfMeansReadAsSamplesSaysPassFormatMeans) {
  const std::string what = input_error_of("n,mean_x,mean_y,mean_z\n100,0.01,0.02,9.8\n");
  EXPECT_NE(what.find("they look like a table of static means: pass --format means"),
            std::string::npos)
      << what;
}

}  // namespace
}  // namespace standcal
