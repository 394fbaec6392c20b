// The streamed recording reader (issue 17): the same numbers and the same errors as the
// reader that holds the whole file, on real files, including lines that straddle its
// 1 MiB blocks.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/decimal.hpp"
#include "calib/line_source.hpp"
#include "calib/programs.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording_digest.hpp"
#include "calib/simulator.hpp"
#include "calib/static_intervals.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"
#include "tests/support/command.hpp"

namespace fs = std::filesystem;
using namespace standcal;

namespace {

class StreamingReader : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("standcal_stream_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = (dir_ / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  fs::path dir_;
};

std::vector<std::string> all_lines(LineSource& source, bool* unterminated = nullptr) {
  std::vector<std::string> out;
  std::string_view line;
  while (source.next(line)) out.emplace_back(line);
  if (unterminated) *unterminated = source.unterminated();
  return out;
}

// Text whose lines cross the 1 MiB block boundary at every offset near it, with CRLF, a
// byte order mark, blank lines, one line longer than a block and no final newline.
std::string awkward_text() {
  std::string text = "\xEF\xBB\xBF# first\r\n\n";
  std::mt19937 rng(3);
  while (text.size() < (std::size_t{1} << 20) + 5000) {
    text += std::string(rng() % 200, 'a' + static_cast<char>(rng() % 26));
    text += (rng() % 3 == 0) ? "\r\n" : "\n";
  }
  text += std::string((std::size_t{3} << 20) / 2, 'L') + "\n";
  text += "last line without newline";
  return text;
}

TEST_F(StreamingReader, AFileReadInBlocksGivesTheLinesOfTheTextInMemory) {
  const std::string text = awkward_text();
  const std::string path = write("awkward.txt", text);
  LineSource from_memory = LineSource::of_text(text);
  LineSource from_file = LineSource::of_file(path);
  bool memory_unterminated = false, file_unterminated = false;
  const auto expected = all_lines(from_memory, &memory_unterminated);
  const auto got = all_lines(from_file, &file_unterminated);
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], expected[i]) << "line " << i + 1;
  EXPECT_EQ(got.front(), "# first");  // the byte order mark and the '\r' are not part of it
  EXPECT_EQ(got[1], "");
  EXPECT_EQ(got.back(), "last line without newline");
  EXPECT_TRUE(memory_unterminated);
  EXPECT_TRUE(file_unterminated);
  EXPECT_EQ(from_file.line_number(), static_cast<int>(got.size()));
  EXPECT_EQ(from_file.bytes_consumed(), text.size());
  EXPECT_EQ(from_file.bytes_total(), text.size());
}

TEST_F(StreamingReader, EmptyMissingAndDirectoryInputsAreToldApart) {
  LineSource empty = LineSource::of_file(write("empty.txt", ""));
  std::string_view line;
  EXPECT_FALSE(empty.next(line));
  try {
    LineSource::of_file((dir_ / "absent.csv").string());
    FAIL() << "a missing file was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("absent.csv: cannot open (No such file or directory)"),
              std::string::npos)
        << e.what();
  }
  try {
    LineSource::of_file(dir_.string());
    FAIL() << "a directory was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open (a directory)"), std::string::npos)
        << e.what();
  }
}

TEST(PlainDecimal, GivesTheDoubleFromCharsGivesOrDeclines) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> value(-20, 20);
  for (int i = 0; i < 200000; ++i) {
    char text[64];
    const int decimals = static_cast<int>(rng() % 12);
    const int n =
        std::snprintf(text, sizeof text, "%.*f", decimals, value(rng) * std::pow(10.0, rng() % 6));
    double expected = 0, got = 0;
    std::from_chars(text, text + n, expected);
    if (parse_plain_decimal({text, static_cast<std::size_t>(n)}, got)) {
      ASSERT_EQ(std::memcmp(&got, &expected, sizeof got), 0) << text;  // bit for bit, -0.0 too
    }
  }
  double v = 0;
  EXPECT_TRUE(parse_plain_decimal("9.816196357", v));
  EXPECT_EQ(v, 9.816196357);
  EXPECT_TRUE(parse_plain_decimal(".5", v));
  EXPECT_EQ(v, 0.5);
  // Long mantissas each side of the point, up to the 15 digits the fast path takes.
  for (const char* text :
       {"12345678.5", "0.12345678", "-123456789012345", "99999999.9999999", "0000000.00000001"}) {
    double expected = 0;
    std::from_chars(text, text + std::strlen(text), expected);
    EXPECT_TRUE(parse_plain_decimal(text, v)) << text;
    EXPECT_EQ(v, expected) << text;
  }
  EXPECT_FALSE(parse_plain_decimal("1234567812345678", v));  // 16 digits
  EXPECT_FALSE(parse_plain_decimal("12345678a.5", v));
  for (const char* declined :
       {"", "-", ".", "1e3", "+1", " 1", "1 ", "1.2.3", "nan", "1234567890.1234567", "x"})
    EXPECT_FALSE(parse_plain_decimal(declined, v)) << declined;
}

// The reference: the overlapping Allan variance written out (IEEE 1293 eq.), pooled.
std::vector<AllanPoint> naive_allan(const std::vector<std::vector<double>>& segments, double tau0) {
  std::size_t longest = 0;
  for (const auto& s : segments) longest = std::max(longest, s.size());
  std::vector<AllanPoint> out;
  long previous = 0;
  for (int step = 0;; ++step) {
    const long m = std::lround(std::pow(10.0, step / 10.0));
    if (m > static_cast<long>(longest / 3)) break;
    if (m == previous) continue;
    previous = m;
    double sum = 0;
    long terms = 0;
    for (const auto& y : segments) {
      for (long k = 0; k + 2 * m <= static_cast<long>(y.size()); ++k) {
        double a = 0, b = 0;
        for (long j = 0; j < m; ++j) {
          a += y[static_cast<std::size_t>(k + j)];
          b += y[static_cast<std::size_t>(k + m + j)];
        }
        const double d = (b - a) / static_cast<double>(m);
        sum += d * d;
        ++terms;
      }
    }
    if (terms > 0) out.push_back({m * tau0, std::sqrt(sum / (2.0 * terms)), terms});
  }
  return out;
}

TEST(AllanAccumulator, PoolsSegmentsFedOneAtATimeAsTheFormulaSays) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 30);
  std::vector<std::vector<double>> segments;
  for (std::size_t n : {500u, 1300u, 90u, 2u}) {
    std::vector<double> s(n);
    double walk = 0;
    for (double& v : s) v = 1e6 + (walk += 0.3 * noise(rng)) + noise(rng);
    segments.push_back(s);
  }
  const auto expected = naive_allan(segments, 0.01);
  const auto got = overlapping_allan_deviation(segments, 0.01);
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_DOUBLE_EQ(got[i].tau_s, expected[i].tau_s);
    EXPECT_EQ(got[i].terms, expected[i].terms);
    EXPECT_NEAR(got[i].deviation, expected[i].deviation, 1e-7 * expected[i].deviation)
        << "tau " << got[i].tau_s;
  }
}

Recording small_run(bool with_rate_header) {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 3;
  req.seed = 9;
  Recording rec = simulate_run(req);
  if (!with_rate_header) {
    rec.sample_rate_hz = kNoValue;
    std::erase_if(rec.header, [](const auto& kv) { return kv.first == "sample_rate_hz"; });
  }
  return rec;
}

void expect_same_averages(const std::vector<PositionAverage>& a,
                          const std::vector<PositionAverage>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].pos, b[i].pos);
    EXPECT_EQ(a[i].mean_g, b[i].mean_g) << "position " << a[i].pos;
    EXPECT_EQ(a[i].standard_error_g, b[i].standard_error_g);
    EXPECT_EQ(a[i].samples, b[i].samples);
    EXPECT_EQ(a[i].approach, b[i].approach);
    EXPECT_EQ(a[i].t_arrive_s, b[i].t_arrive_s);
    EXPECT_EQ(a[i].mount, b[i].mount);
  }
}

TEST_F(StreamingReader, TheDigestIsWhatTheWholeRecordingGives) {
  for (const bool rate_header : {true, false}) {
    SCOPED_TRACE(rate_header ? "with sample_rate_hz" : "without sample_rate_hz");
    const std::string path = (dir_ / "run.csv").string();
    write_recording(small_run(rate_header), path);
    const Recording whole = read_recording(path);
    const RecordingDigest digest = digest_recording(path);
    EXPECT_EQ(digest.samples, whole.samples.size());
    EXPECT_TRUE(digest.recording.samples.empty());
    EXPECT_EQ(digest.recording.header, whole.header);
    EXPECT_EQ(digest.recording.warnings, whole.warnings);
    expect_same_averages(digest.averages, average_positions(whole));
    const DwellAllan expected = dwell_allan(whole);
    ASSERT_TRUE(digest.allan) << digest.allan_unavailable;
    EXPECT_EQ(digest.allan->segments, expected.segments);
    EXPECT_DOUBLE_EQ(digest.allan->sample_period_s, expected.sample_period_s);
    for (std::size_t a = 0; a < 3; ++a) {
      ASSERT_EQ(digest.allan->curves[a].size(), expected.curves[a].size());
      for (std::size_t i = 0; i < expected.curves[a].size(); ++i)
        EXPECT_DOUBLE_EQ(digest.allan->curves[a][i].deviation, expected.curves[a][i].deviation);
    }
  }
}

// A stand recording without a rate header whose times are 1e-300 s apart (or all equal):
// the Allan curves of `noise`, `fit` and `diagnose` took a sample period of 1e-300 s (0 s)
// from the median step, without a word. No unit samples faster than 1e6 a second: the
// period is refused, the same words in the whole reader, the digest and other tools' reader,
// and `fit` says what it does without the curve.
TEST_F(StreamingReader, TimeStepsNoUnitMakesGiveNoSamplePeriod) {
  const std::string written = (dir_ / "run.csv").string();
  write_recording(small_run(false), written);
  const auto with_times = [&](const std::function<std::string(int)>& time_of) {
    std::ifstream in(written);
    std::string text, line;
    bool rows = false;
    int k = 0;
    while (std::getline(in, line)) {
      if (rows) line = time_of(++k) + line.substr(line.find(','));
      rows = rows || line.rfind("t_s,", 0) == 0;
      text += line + "\n";
    }
    return write("steps.csv", text);
  };
  const auto apart = [](const char* step) {
    return [step](int k) { return std::to_string(k) + step; };
  };
  struct Case {
    std::function<std::string(int)> time_of;
    std::string why;  // "": a sample period
  };
  const std::vector<Case> cases{
      {apart("e-300"), "the median time step is 1e-300 s, more than 1e6 samples a second"},
      {[](int) { return std::string("5"); }, "the median time step is zero: repeated time stamps"},
      {apart("e-6"), ""},  // 1 MHz: a rate
      {apart("e-7"), "the median time step is 1e-07 s, more than 1e6 samples a second"}};
  for (const Case& c : cases) {
    const std::string path = with_times(c.time_of);
    SCOPED_TRACE(c.time_of(1) + " s for the first sample");
    if (c.why.empty()) {
      EXPECT_NEAR(dwell_allan(read_recording(path)).sample_period_s, 1e-6, 1e-15);
      EXPECT_TRUE(digest_recording(path).allan);
      EXPECT_NEAR(read_input(path).sample_rate_hz, 1e6, 1e-3);
      continue;
    }
    try {
      (void)dwell_allan(read_recording(path));
      ADD_FAILURE() << "an Allan curve from these steps";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("steps.csv: " + c.why), std::string::npos) << e.what();
    }
    const RecordingDigest digest = digest_recording(path);
    EXPECT_FALSE(digest.allan);
    EXPECT_NE(digest.allan_unavailable.find("steps.csv: " + c.why), std::string::npos)
        << digest.allan_unavailable;
    const RawInput raw = read_input(path);
    EXPECT_TRUE(std::isnan(raw.sample_rate_hz)) << raw.sample_rate_hz;
    ASSERT_FALSE(raw.warnings.empty());
    EXPECT_NE(raw.warnings.back().find(c.why), std::string::npos) << raw.warnings.back();
    const std::string db = "sqlite://" + (dir_ / "lab.sqlite").string();
    for (const std::string& command :
         {"fit " + path, "diagnose " + path, "import " + path + " --db " + db}) {
      const test::CommandOutcome said = test::standcal_cli(command);
      EXPECT_NE(said.output.find(path + ": " + c.why), std::string::npos)
          << command << ": " << said.output;
      EXPECT_NE(said.output.find("the dwells have no Allan curve"), std::string::npos)
          << command << ": " << said.output;
    }
    // The operator's --rate-hz is the period, streamed or read whole (a pipe): it was not
    // applied to a stand recording, whose reader then still said "(pass --rate-hz)".
    for (const std::string& command :
         {std::string(STANDCAL_CLI_PATH) + " fit " + path + " --rate-hz 1000",
          std::string(STANDCAL_CLI_PATH) + " diagnose " + path + " --rate-hz 1000",
          "cat " + path + " | " + STANDCAL_CLI_PATH + " fit /dev/stdin --rate-hz 1000",
          "cat " + path + " | " + STANDCAL_CLI_PATH + " diagnose /dev/stdin --rate-hz 1000"}) {
      const test::CommandOutcome said = test::run_command(command);
      EXPECT_EQ(said.output.find("no Allan curve"), std::string::npos)
          << command << ": " << said.output;
      EXPECT_EQ(said.output.find("pass --rate-hz"), std::string::npos)
          << command << ": " << said.output;
      // fit exits 0; diagnose with its verdict's status, not an error's (1) or usage's (2).
      EXPECT_TRUE(said.exit_code == 0 ||
                  (command.find(" diagnose ") != std::string::npos && said.exit_code > 2))
          << command << ": " << said.exit_code << " " << said.output;
    }
    InputOptions given;
    given.rate_hz = 1000;
    const RawInput given_raw = read_input(path, given);
    EXPECT_EQ(given_raw.sample_rate_hz, 1000);
    ASSERT_TRUE(given_raw.recording);
    EXPECT_NEAR(dwell_allan(*given_raw.recording).sample_period_s, 1e-3, 1e-15);
    DigestOptions digest_given;
    digest_given.sample_rate_hz = 1000;
    EXPECT_TRUE(digest_recording(path, digest_given).allan);
  }
}

// `standcal fit`, `diagnose` and `noise` of the file given `option`, and of it through a pipe
// (the source then named /dev/stdin): each says `said`, after the source, in exactly one
// "warning:" line (the fit's report lists the recording's warnings too, not as such lines).
void expect_said_once_by_every_reader(const std::string& path, const std::string& option,
                                      const std::string& said) {
  const std::string cli = STANDCAL_CLI_PATH;
  for (const std::string& command :
       {cli + " fit " + path + " " + option, cli + " diagnose " + path + " " + option,
        cli + " noise " + path + " " + option,
        "cat " + path + " | " + cli + " fit /dev/stdin " + option,
        "cat " + path + " | " + cli + " diagnose /dev/stdin " + option}) {
    const test::CommandOutcome r = test::run_command(command);
    std::istringstream lines(r.output);
    int warned = 0;
    for (std::string line; std::getline(lines, line);)
      warned += line.rfind("warning: ", 0) == 0 && line.find(said) != std::string::npos ? 1 : 0;
    EXPECT_EQ(warned, 1) << command << ": " << r.output;
  }
}

// A recording's own rate is kept over --rate-hz (it was written with the samples), and the
// operator is told once, whichever reader reads it: the option was dropped without a word.
TEST_F(StreamingReader, ARateGivenBesideTheHeadersIsNotUsedAndSaidSo) {
  const std::string path = (dir_ / "run.csv").string();
  write_recording(small_run(true), path);
  const std::string header_rate = round_trip_text(read_recording(path).sample_rate_hz);
  // After the source, which a pipe names /dev/stdin.
  expect_said_once_by_every_reader(path, "--rate-hz 1000",
                                   ": --rate-hz 1000 is not used: the header's sample_rate_hz " +
                                       header_rate + " was written with the samples");
  EXPECT_EQ(read_input(path, InputOptions{}).warnings, read_recording(path).warnings)
      << "no option, no word";
}

// A step longer than any time a recording holds (two samples 1.8e12 s apart) is no period;
// a period of 1e12 s is the slowest rate taken, 1e-12 Hz.
TEST_F(StreamingReader, AStepBeyondAnyTimeIsNoSamplePeriod) {
  EXPECT_NE(unusable_step_text(1.8e12).find("the median time step is 1.8e+12 s, beyond 1e12 s"),
            std::string::npos);
  EXPECT_EQ(unusable_step_text(1e12), "");
  Recording rec;
  rec.source = "far.csv";
  for (const double t_s : {-9e11, 9e11}) {
    RecordingSample s;
    s.t_s = t_s;
    rec.samples.push_back(s);
  }
  try {
    (void)sample_period_s(rec);
    ADD_FAILURE() << "a sample period of 1.8e12 s";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("far.csv: the median time step is 1.8e+12 s, beyond"),
              std::string::npos)
        << e.what();
  }
}

// A unit whose output filter correlates its samples (0.2 s at 10 Hz: sigma / sqrt(n)
// understates a dwell mean's error by sqrt((1 + a) / (1 - a)) = 2.0, a = exp(-1/2)): the
// dwells' pooled Allan curves show it, and the averages of the whole recording and of the
// digest widen each standard error by the same factor.
TEST_F(StreamingReader, SamplesCorrelatedWithinADwellWidenItsStandardErrorInBothReaders) {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 10;
  req.seed = 9;
  req.truth.noise.output_filter_tau_s = 0.2;
  const std::string path = (dir_ / "filtered.csv").string();
  Recording run = simulate_run(req);
  for (const bool rate_header : {true, false}) {
    SCOPED_TRACE(rate_header ? "with sample_rate_hz" : "without sample_rate_hz");
    if (!rate_header) {
      run.sample_rate_hz = kNoValue;
      std::erase_if(run.header, [](const auto& kv) { return kv.first == "sample_rate_hz"; });
    }
    write_recording(run, path);
    const Recording whole = read_recording(path);
    const RecordingDigest digest = digest_recording(path);
    const AveragedRecording averaged = average_recording(whole);
    expect_same_averages(digest.averages, averaged.averages);
    ASSERT_TRUE(digest.allan && digest.allan->sample_correlation);
    ASSERT_TRUE(averaged.allan && averaged.allan->sample_correlation);
    const Vec3 factor = digest.allan->sample_correlation->factor;
    EXPECT_EQ(factor, averaged.allan->sample_correlation->factor);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(factor[a], 2.02, 0.25) << a;
    for (const PositionAverage& p : averaged.averages) {
      const Vec3 white = p.sigma_g / std::sqrt(static_cast<double>(p.samples));
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(p.standard_error_g[a], white[a] * factor[a], 1e-12 * white[a]) << p.pos;
        EXPECT_NEAR(correlation_widening(p, a), factor[a], 1e-9) << p.pos;
      }
    }
  }
  // Independent samples (the same run without the filter) are left as sigma / sqrt(n).
  req.truth.noise.output_filter_tau_s = 0;
  write_recording(simulate_run(req), path);
  const RecordingDigest white_digest = digest_recording(path);
  ASSERT_TRUE(white_digest.allan);
  EXPECT_FALSE(white_digest.allan->sample_correlation);
}

TEST_F(StreamingReader, AGivenGravityIsUsedAndItsWarningDropped) {
  Recording rec = small_run(true);
  std::erase_if(rec.header, [](const auto& kv) { return kv.first == "g_local_mps2"; });
  const std::string path = (dir_ / "no_g.csv").string();
  write_recording(rec, path);
  EXPECT_EQ(digest_recording(path).recording.warnings.size(), 1u);  // g assumed
  DigestOptions options;
  options.g_mps2 = 9.80;
  const RecordingDigest digest = digest_recording(path, options);
  EXPECT_TRUE(digest.recording.warnings.empty());
  EXPECT_EQ(digest.recording.g_local_mps2, 9.80);
  Recording whole = read_recording(path);
  whole.g_local_mps2 = 9.80;
  expect_same_averages(digest.averages, average_positions(whole));
}

// A g given beside a header's replaces it (a g measured since the recording), and the
// operator is told once, whichever reader reads it, with what it does to the scale factors:
// the option replaced the header's g without a word.
TEST_F(StreamingReader, AGravityGivenBesideTheHeadersReplacesItAndIsSaidSo) {
  const std::string path = (dir_ / "run.csv").string();
  write_recording(small_run(true), path);
  const std::string header_g = round_trip_text(read_recording(path).g_local_mps2);
  ASSERT_NE(header_g, "9.8");
  expect_said_once_by_every_reader(path, "--g-mps2 9.8",
                                   ": --g-mps2 9.8 replaces the header's g_local_mps2 " + header_g);
  InputOptions given;
  given.g_mps2 = 9.8;
  const RawInput replaced = read_input(path, given);
  EXPECT_EQ(replaced.g_mps2, 9.8);
  ASSERT_TRUE(replaced.recording);
  EXPECT_EQ(replaced.recording->g_local_mps2, 9.8);
  given.g_mps2 = read_recording(path).g_local_mps2;  // the header's own g: nothing said
  EXPECT_EQ(read_input(path, given).warnings, read_recording(path).warnings);
}

// Every way a row can be wrong, in a still column (parsed only when its text changes) or
// a moving one: streamed and whole reading name the same line, column and reason.
TEST_F(StreamingReader, BadRowsAreReportedAsTheWholeReaderReportsThem) {
  const std::string head =
      "# format: standcal-recording/1\n# g_local_mps2: 9.81\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,mount,approach\n"
      "0.00,0,0,0,0,9.81,0,x,1\n0.01,0,0,0,0,9.81,0,x,1\n";
  const std::vector<std::string> bad_rows = {
      "0.02,0,0,abc,0,9.81,0,x,1\n",  // a still column that is not a number
      "0.02,0,0,5,0,9.81,0,x,1\n",    // commanded angles change inside a position
      "0.02,0,0,0,0,9.81,0,q,1\n",    // not a mount
      "0.02,0,0,0,0,9.81,0,x,2\n",    // not an approach
      "0.02,-1,0,0,0,9.81,0,x,1\n",   // not a position index
      "0.02,0,0,0,0,9.8x,0,x,1\n",    // a moving column that is not a number
      "0.00,0,0,0,0,9.81,0,x,1\n0.001,1,90,0,9.81,0,0,x,1\n"
      "0.002,0,0,0,0,9.81,0,x,1\n",  // time backwards, then a position again
      "0.02,0,0,0,0,9.81\n",         // too few fields
  };
  for (const std::string& bad : bad_rows) {
    SCOPED_TRACE(bad);
    const std::string path = write("bad.csv", head + bad + "0.03,0,0,0,0,9.81,0,x,1\n");
    std::string whole_error, streamed_error;
    try {
      read_recording(path);
    } catch (const RecordingError& e) {
      whole_error = e.what();
    }
    try {
      digest_recording(path);
    } catch (const RecordingError& e) {
      streamed_error = e.what();
    }
    EXPECT_FALSE(whole_error.empty());
    EXPECT_EQ(streamed_error, whole_error);
  }
}

// The reader's quick path (a dwell's rows as the writers write them) against its general
// path, which reads every row it declines: rows whose moving numbers carry a leading space
// go the general way, and a recording read with some, all or none of its rows so
// decorated gives the same samples, bit for bit.
std::string with_spaced_numbers(const std::string& row, const std::vector<std::size_t>& moving) {
  std::vector<std::string> fields(1);
  for (const char c : row) {
    if (c == ',')
      fields.emplace_back();
    else
      fields.back() += c;
  }
  for (std::size_t i : moving) fields[i] = " " + fields[i];
  std::string out;
  for (std::size_t i = 0; i < fields.size(); ++i) out += (i ? "," : "") + fields[i];
  return out;
}

// Every `every`-th row (0: none) with spaced numbers.
std::string decorated_text(const Recording& rec, const std::vector<std::size_t>& moving,
                           const std::string& extra_column, std::size_t every) {
  std::string rows;
  append_recording_rows(rows, rec.columns, rec.samples);
  std::string header = format_recording_header(rec);
  if (!extra_column.empty()) header.insert(header.size() - 1, "," + extra_column);
  std::string out = header;
  std::size_t i = 0;
  for (std::size_t start = 0; start < rows.size(); ++i) {
    const std::size_t end = rows.find('\n', start);
    std::string row = rows.substr(start, end - start);
    if (!extra_column.empty()) row += ",ok";
    out += (every && i % every == 0 ? with_spaced_numbers(row, moving) : row) + "\n";
    start = end + 1;
  }
  return out;
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

void expect_same_samples(const Recording& a, const Recording& b) {
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    const RecordingSample& x = a.samples[i];
    const RecordingSample& y = b.samples[i];
    SCOPED_TRACE("row " + std::to_string(i));
    EXPECT_TRUE(same_bits(x.t_s, y.t_s));
    EXPECT_TRUE(same_bits(x.alpha1_cmd_deg, y.alpha1_cmd_deg));
    EXPECT_TRUE(same_bits(x.alpha2_cmd_deg, y.alpha2_cmd_deg));
    EXPECT_TRUE(same_bits(x.alpha1_deg, y.alpha1_deg));
    EXPECT_TRUE(same_bits(x.alpha2_deg, y.alpha2_deg));
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(x.f_mps2[k], y.f_mps2[k])) << "axis " << k;
    EXPECT_TRUE(same_bits(x.temp_c, y.temp_c));
    EXPECT_TRUE(same_bits(x.t_arrive_s, y.t_arrive_s));
    EXPECT_EQ(x.pos, y.pos);
    EXPECT_EQ(x.approach, y.approach);
    EXPECT_EQ(x.mount, y.mount);
    if (::testing::Test::HasFailure()) return;  // one row's difference is enough to read
  }
}

TEST(QuickRows, AreReadAsTheGeneralPathReadsThem) {
  Recording all_columns = small_run(true);
  // Every standcal column: t_s, fx, fy, fz, temp_c move (fields 0, 6, 7, 8, 9).
  const std::vector<std::size_t> moving_all{0, 6, 7, 8, 9};
  // No measured angles and no temperature, and a column the reader does not know (after
  // approach): t_s, fx, fy, fz move (fields 0, 4, 5, 6).
  Recording fewer_columns = all_columns;
  fewer_columns.columns.alpha_measured = false;
  fewer_columns.columns.temp = false;
  const std::vector<std::size_t> moving_fewer{0, 4, 5, 6};
  for (const auto& [rec, moving, extra] :
       {std::tuple{all_columns, moving_all, std::string()},
        std::tuple{fewer_columns, moving_fewer, std::string("note")}}) {
    const Recording general = parse_recording(decorated_text(rec, moving, extra, 1), "general");
    ASSERT_EQ(general.samples.size(), rec.samples.size());
    for (const std::size_t every : {0u, 2u, 7u}) {
      SCOPED_TRACE("every " + std::to_string(every) + "th row spaced, extra column '" + extra +
                   "'");
      expect_same_samples(parse_recording(decorated_text(rec, moving, extra, every), "mixed"),
                          general);
    }
  }
}

// A file read in two parts as the CLI reads a large one (tools/standcal/threaded_rows.cpp,
// there on two threads): the first part up to a dwell found after the middle, the rest by
// a part reader into a digester of its own, appended.
struct TwoParts {
  RecordingDigester first;
  RecordingDigester later;
  std::optional<RecordingDigest> digest;  // when the part continues the first
};

std::unique_ptr<TwoParts> digest_in_two_parts(const std::string& path) {
  auto parts = std::make_unique<TwoParts>();
  RecordingReader reader(path);
  const Recording& head = reader.read_header(parts->first);
  parts->later.header(head);
  parts->later.keep_for_append();
  const std::optional<std::size_t> split =
      reader.dwell_start_after(reader.bytes_total() / 2, std::size_t{1} << 20);
  if (!split) return parts;
  RecordingPartReader part = reader.part_from(*split);
  const std::atomic<bool> cancel{false};
  const bool part_read = part.read(parts->later, cancel);
  reader.read_rows(parts->first, *split);
  if (!part_read || !reader.continues_with(part)) return parts;
  parts->first.append(std::move(parts->later));
  parts->digest = parts->first.finish(reader.finish());
  return parts;
}

TEST_F(StreamingReader, AFileReadInTwoPartsDigestsAsOneReadInOrder) {
  const std::string path = (dir_ / "run.csv").string();
  write_recording(small_run(true), path);
  const RecordingDigest in_order = digest_recording(path);
  const std::unique_ptr<TwoParts> two = digest_in_two_parts(path);
  ASSERT_TRUE(two->digest);
  EXPECT_EQ(two->digest->samples, in_order.samples);
  EXPECT_EQ(two->digest->recording.header, in_order.recording.header);
  EXPECT_EQ(two->digest->recording.warnings, in_order.recording.warnings);
  expect_same_averages(two->digest->averages, in_order.averages);
  ASSERT_TRUE(two->digest->allan && in_order.allan);
  EXPECT_EQ(two->digest->allan->segments, in_order.allan->segments);
  for (std::size_t a = 0; a < 3; ++a) {
    ASSERT_EQ(two->digest->allan->curves[a].size(), in_order.allan->curves[a].size());
    for (std::size_t i = 0; i < in_order.allan->curves[a].size(); ++i) {
      EXPECT_EQ(two->digest->allan->curves[a][i].deviation,
                in_order.allan->curves[a][i].deviation);  // the same sums, in the same order
      EXPECT_EQ(two->digest->allan->curves[a][i].terms, in_order.allan->curves[a][i].terms);
    }
  }
}

// A warm-up (the programme's warmup_s, the recording's header `warmup_s`): the first position's
// rows within it of the block's first are the unit settling and showing its noise, not a
// measurement. They feed the Allan curves and stay out of that position's mean, in memory,
// streamed and in two parts alike: the mean is that of the measured rows to the last bit, its
// time the measured rows', and a settling put into the warm-up moves nothing. Without the
// header the same rows are a 610 s dwell, the settling in its mean.
TEST_F(StreamingReader, AWarmUpFeedsTheCurvesAndStaysOutOfItsPositionsMean) {
  SimulationRequest req;
  req.program = paper9();
  req.program.warmup_s = 600;
  req.timing.dwell_s = 10;
  req.timing.sample_rate_hz = 25;
  req.seed = 4;
  Recording rec = simulate_run(req);
  ASSERT_EQ(rec.header_value(kHeaderWarmupS), "600");
  const double first_s = rec.samples.front().t_s;
  std::size_t warm_rows = 0;
  for (RecordingSample& x : rec.samples)
    if (x.pos == 0 && x.t_s < first_s + 600) {
      x.f_mps2 += Vec3::Constant(100 * kUg * rec.g_local_mps2);  // a settling of 100 ug
      ++warm_rows;
    }
  ASSERT_EQ(warm_rows, 15000u);
  const std::string path = (dir_ / "warm.csv").string();
  write_recording(rec, path);
  const Recording whole = read_recording(path);
  EXPECT_DOUBLE_EQ(whole.warmup_s, 600);
  Recording measured = whole;  // the same rows without the warm-up's, and no warm-up
  std::erase_if(measured.samples,
                [&](const RecordingSample& x) { return x.pos == 0 && x.t_s < first_s + 600; });
  measured.warmup_s = 0;
  const std::vector<PositionAverage> expected = average_positions(measured);

  const AveragedRecording in_memory = average_recording(whole);
  ASSERT_EQ(in_memory.averages.size(), 9u);
  EXPECT_EQ(in_memory.averages[0].samples, 250u);
  EXPECT_EQ(in_memory.averages[0].mean_g, expected[0].mean_g);
  EXPECT_EQ(in_memory.averages[0].standard_error_g, expected[0].standard_error_g);
  EXPECT_DOUBLE_EQ(in_memory.averages[0].t_start_s, measured.samples.front().t_s);
  EXPECT_DOUBLE_EQ(in_memory.averages[0].t_arrive_s, rec.samples.front().t_arrive_s);
  const RecordingDigest digest = digest_recording(path);
  expect_same_averages(digest.averages, in_memory.averages);
  const std::unique_ptr<TwoParts> two = digest_in_two_parts(path);
  ASSERT_TRUE(two->digest);
  expect_same_averages(two->digest->averages, in_memory.averages);
  // The curves hold the warm-up: they reach a third of its 610 s block, where the 10 s
  // dwells alone end at 3.3 s.
  ASSERT_TRUE(digest.allan && in_memory.allan);
  EXPECT_GT(digest.allan->curves[0].back().tau_s, 150);
  EXPECT_EQ(dwell_allan(whole).curves[0].back().tau_s, digest.allan->curves[0].back().tau_s);

  // The norm fit of the same recording without its angles takes its intervals from the
  // blocks alike: the warm-up in the curves, not in position 0's interval.
  const StaticDetection blocks = detect_static_intervals(raw_input_of(whole));
  ASSERT_EQ(blocks.intervals.size(), 9u);
  EXPECT_EQ(blocks.intervals[0].samples, 250u);
  EXPECT_EQ(blocks.warm_up.second - blocks.warm_up.first, 15000u);
  EXPECT_GT(blocks.allan[0].back().tau_s, 150);

  Recording without = whole;
  without.warmup_s = 0;
  const std::vector<PositionAverage> dwell_of_610_s = average_positions(without);
  EXPECT_EQ(dwell_of_610_s[0].samples, 15250u);
  EXPECT_NEAR((dwell_of_610_s[0].mean_g - expected[0].mean_g).mean() / kUg, 100 * 600 / 610.0,
              12);  // 4 sigma of the 10 s mean's 3.2 ug
  // A warm-up that leaves the position fewer than two measured rows is refused, saying so.
  Recording all_warm_up = whole;
  all_warm_up.warmup_s = 1e6;
  try {
    (void)average_positions(all_warm_up);
    ADD_FAILURE() << "a position of warm-up alone was averaged";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("after its warm-up of 1e+06 s"), std::string::npos)
        << e.what();
  }
}

// A part that does not follow on from the rows before it is not taken: its first row goes
// back in time, or it holds a position the first part already had (one reader in order
// names the line of either; the CLI then reads the part in order).
TEST_F(StreamingReader, APartThatDoesNotFollowOnIsNotTaken) {
  const std::string head =
      "# format: standcal-recording/1\n# g_local_mps2: 9.81\n# sample_rate_hz: 100\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n";
  auto rows = [](int pos, double t0_s, int count) {
    std::string out;
    for (int i = 0; i < count; ++i)
      out += std::to_string(t0_s + i * 0.01) + "," + std::to_string(pos) + ",0,0,0,0,9.81\n";
    return out;
  };
  // The middle of each file falls in position 1's rows; the part begins after them.
  const std::string follows =
      write("follows.csv", head + rows(0, 0, 300) + rows(1, 3, 200) + rows(2, 5, 300));
  const std::string position_again =
      write("again.csv", head + rows(0, 0, 300) + rows(1, 3, 200) + rows(0, 5, 300));
  const std::string time_back =
      write("back.csv", head + rows(0, 10, 300) + rows(1, 13, 200) + rows(2, 0, 300));
  EXPECT_TRUE(digest_in_two_parts(follows)->digest);
  EXPECT_FALSE(digest_in_two_parts(position_again)->digest);
  EXPECT_FALSE(digest_in_two_parts(time_back)->digest);
  for (const std::string& bad : {position_again, time_back})
    EXPECT_THROW(digest_recording(bad), RecordingError) << bad;
}

// A file renamed over the path while the first part is read (a run rewritten with
// `standcal simulate -o` or a copy) is not mixed in, even when its rows would follow on:
// here it is the same recording, so only the file's identity tells them apart.
TEST_F(StreamingReader, APartOfAFileRenamedOverThePathIsNotTaken) {
  const std::string path = (dir_ / "run.csv").string();
  const std::string copy = (dir_ / "copy.csv").string();
  write_recording(small_run(true), path);
  fs::copy_file(path, copy);
  RecordingDigester first, later;
  RecordingReader reader(path);
  later.header(reader.read_header(first));
  const std::optional<std::size_t> split =
      reader.dwell_start_after(reader.bytes_total() / 2, std::size_t{1} << 20);
  ASSERT_TRUE(split);
  fs::rename(copy, path);
  EXPECT_FALSE(reader.dwell_start_after(reader.bytes_total() / 2, std::size_t{1} << 20));
  RecordingPartReader part = reader.part_from(*split);
  const std::atomic<bool> cancel{false};
  EXPECT_TRUE(part.read(later, cancel));
  reader.read_rows(first, *split);
  EXPECT_FALSE(reader.continues_with(part));
}

TEST(AllanAccumulator, AppendedSegmentsGiveTheCurveOfAddingThemInOrder) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 1);
  std::vector<std::vector<double>> segments;
  for (const std::size_t n : {3000u, 1200u, 4000u, 10u, 2500u}) {
    segments.emplace_back(n);
    for (double& v : segments.back()) v = noise(rng);
  }
  AllanAccumulator in_order(0.01), first(0.01), later(0.01);
  later.keep_segment_sums();
  for (std::size_t i = 0; i < segments.size(); ++i) {
    std::vector<double> a = segments[i], b = segments[i];
    in_order.add_segment(a);
    (i < 2 ? first : later).add_segment(b);
  }
  first.append(later);
  const std::vector<AllanPoint> expected = in_order.curve(), got = first.curve();
  EXPECT_EQ(first.segments(), in_order.segments());
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].tau_s, expected[i].tau_s);
    EXPECT_EQ(got[i].deviation, expected[i].deviation);
    EXPECT_EQ(got[i].terms, expected[i].terms);
  }
  AllanAccumulator unkept(0.01);
  std::vector<double> c = segments[0];
  unkept.add_segment(c);
  EXPECT_THROW(first.append(unkept), std::logic_error);
}

TEST_F(StreamingReader, AStillColumnThatEmptiesIsReadAsEmpty) {
  const std::string path =
      write("mount.csv",
            "# format: standcal-recording/1\n# g_local_mps2: 9.81\n# mount: z\n"
            "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,mount,approach\n"
            "0.00,0,0,0,0,9.81,0,y,-1\n0.01,0,0,0,0,9.81,0,,\n");
  const Recording rec = read_recording(path);
  ASSERT_EQ(rec.samples.size(), 2u);
  EXPECT_EQ(rec.samples[0].mount, Mount::y);
  EXPECT_EQ(rec.samples[0].approach, -1);
  EXPECT_FALSE(rec.samples[1].mount.has_value());
  EXPECT_EQ(rec.samples[1].approach, 0);
}

// The CLI parses on one thread and averages on another; an error still comes out as the
// one-thread reading raises it: a position with too few samples before a bad line later
// is reported, not the later line.
TEST_F(StreamingReader, TheTwoThreadFitReportsTheFirstErrorOfTheFile) {
  std::string text =
      "# format: standcal-recording/1\n# g_local_mps2: 9.81\n# sample_rate_hz: 100\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n"
      "0.00,0,0,0,0,9.81,0\n";  // position 0: one sample
  for (int i = 0; i < 10000; ++i) text += std::to_string(1 + i * 0.01) + ",1,90,0,9.81,0,0\n";
  const std::string first_error = write("first.csv", text + "200.0,2,0,90,0,0,bad\n");
  std::string single_thread;
  try {
    digest_recording(first_error);
  } catch (const std::exception& e) {
    single_thread = e.what();
  }
  ASSERT_NE(single_thread.find("position 0 has 1 usable sample"), std::string::npos)
      << single_thread;
  const auto fit = standcal::test::standcal_cli("fit " + first_error + " --json");
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(fit.output.find(single_thread), std::string::npos) << fit.output;

  // The same when the bad line comes right after: the rows before it were never handed to
  // the averaging thread in a full batch, and still come first.
  const std::string right_after =
      write("right_after.csv", text.substr(0, text.find("1.000000,1")) +
                                   "1.00,1,90,0,9.81,0,0\n1.01,1,90,0,9.81,0,bad\n");
  const auto near = standcal::test::standcal_cli("fit " + right_after + " --json");
  EXPECT_NE(near.exit_code, 0);
  EXPECT_NE(near.output.find("position 0 has 1 usable sample"), std::string::npos) << near.output;

  const std::string parse_error = write("parse.csv", text.replace(text.find("0.00,0,0,0"), 1, "x"));
  const auto bad = standcal::test::standcal_cli("fit " + parse_error + " --json");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("parse.csv:5: column 1: column 't_s': 'x.00' is not a number"),
            std::string::npos)
      << bad.output;
}

// What the reader warned about is said even when the fit then fails: a recording whose
// only sample row was cut off mid-write says so, not only "no samples". (Regression: the
// streamed fit printed the reader's warnings only once the whole digest had succeeded.)
TEST_F(StreamingReader, TheReadersWarningsArePrintedWhenTheFitThenFails) {
  const std::string path =
      write("cut.csv",
            "# format: standcal-recording/1\n# g_local_mps2: 9.81\n# sample_rate_hz: 100\n"
            "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n"
            "0.00,0,0,0,0,9.8");  // the run stopped mid-line
  const auto fit = standcal::test::standcal_cli("fit " + path + " --json");
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(fit.output.find("no samples"), std::string::npos) << fit.output;
  EXPECT_NE(fit.output.find("last line has no newline"), std::string::npos) << fit.output;
}

// A recording can come through a pipe (`zcat run.csv.gz | standcal fit /dev/stdin`): it
// cannot be opened twice nor sized, and is read whole, once. (Regression: the format probe
// consumed the pipe's first block, and the reader's size query closed a pipe it opened.)
TEST_F(StreamingReader, ARecordingThroughAPipeIsFittedAndDiagnosedAsTheFile) {
  const std::string path = (dir_ / "run.csv").string();
  write_recording(small_run(true), path);
  const auto from_file = standcal::test::standcal_cli("fit " + path + " --json");
  const auto piped = standcal::test::run_command("cat " + path + " | " + STANDCAL_CLI_PATH +
                                                 " fit /dev/stdin --json");
  ASSERT_EQ(from_file.exit_code, 0) << from_file.output;
  ASSERT_EQ(piped.exit_code, 0) << piped.output;
  EXPECT_EQ(nlohmann::json::parse(piped.output), nlohmann::json::parse(from_file.output));
  const auto diagnosed = standcal::test::run_command("cat " + path + " | " + STANDCAL_CLI_PATH +
                                                     " diagnose /dev/stdin --json");
  const auto diagnosed_file = standcal::test::standcal_cli("diagnose " + path + " --json");
  EXPECT_EQ(diagnosed.exit_code, diagnosed_file.exit_code) << diagnosed.output;  // a verdict's code
  EXPECT_EQ(nlohmann::json::parse(diagnosed.output)["verdict"],
            nlohmann::json::parse(diagnosed_file.output)["verdict"]);
  const std::string xsens = std::string(STANDCAL_TEST_DATA) + "/imu_tk_xsens/xsens_acc.mat";
  const auto imu_tk = standcal::test::run_command("cat " + xsens + " | " + STANDCAL_CLI_PATH +
                                                  " fit /dev/stdin --json --g-mps2 9.81744");
  EXPECT_EQ(imu_tk.exit_code, 0) << imu_tk.output.substr(0, 400);
}

// --units mps2 is the default reading; --skip-lines 0 too, but --format standcal with
// --columns forces the whole-file reader: both paths must print the same fit.
void expect_streamed_fit_is_whole_files(const std::string& path) {
  const auto streamed = standcal::test::standcal_cli("fit " + path + " --json");
  const auto whole =
      standcal::test::standcal_cli("fit " + path + " --json --columns fx_mps2,fy_mps2,fz_mps2");
  ASSERT_EQ(streamed.exit_code, 0) << streamed.output;
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  EXPECT_EQ(nlohmann::json::parse(streamed.output), nlohmann::json::parse(whole.output));
}

TEST_F(StreamingReader, TheCliFitOfAStreamedFileEqualsTheFitOfTheWholeFile) {
  const std::string path = (dir_ / "run.csv").string();
  write_recording(small_run(true), path);
  expect_streamed_fit_is_whole_files(path);
}

// A file of 4 MiB or more is read by the CLI in two parts at once (one thread each,
// tools/standcal/threaded_rows.cpp): its fit is the whole-file reader's, and a file with
// an error or a cut-off last line in its second part is told about as one reader in order
// tells it (the part is then read again in order).
TEST_F(StreamingReader, ALargeFileReadInTwoPartsIsFittedAndCheckedAsOneReadInOrder) {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 20;  // 24 x 20 s x 100 Hz = 48 000 rows, 5.4 MB
  const std::string path = (dir_ / "large.csv").string();
  write_recording(simulate_run(req), path);
  ASSERT_GE(fs::file_size(path), std::size_t{4} << 20);
  expect_streamed_fit_is_whole_files(path);

  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto expect_told_as_in_order = [&](const std::string& name, const std::string& changed) {
    SCOPED_TRACE(name);
    const std::string file = write(name, changed);
    std::string in_order;
    try {
      const RecordingDigest d = digest_recording(file);
      for (const std::string& w : d.recording.warnings) in_order += w;
    } catch (const std::exception& e) {
      in_order = e.what();
    }
    ASSERT_FALSE(in_order.empty());
    const auto fit = standcal::test::standcal_cli("fit " + file + " --json");
    EXPECT_NE(fit.output.find(in_order), std::string::npos) << in_order << "\n" << fit.output;
  };
  // A bad number three quarters in, and a last line cut off mid-write.
  const std::size_t late_row = text.find('\n', text.size() * 3 / 4) + 1;
  std::string bad_number = text;
  bad_number.insert(text.find(',', late_row) + 1, "x");
  expect_told_as_in_order("bad_number.csv", bad_number);
  expect_told_as_in_order("cut.csv", text.substr(0, text.size() - 20));
  // A position of the first part again in the second (its rows must be contiguous):
  // positions 0, 1, 0 of 60 000 rows each, the middle in position 1.
  std::string again =
      "# format: standcal-recording/1\n# g_local_mps2: 9.81\n# sample_rate_hz: 100\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n";
  for (int i = 0; i < 180000; ++i)
    again +=
        std::to_string(i * 0.01) + (i / 60000 == 1 ? ",1,90,0,9.81,0,0\n" : ",0,0,0,0,0,9.81\n");
  ASSERT_GE(again.size(), std::size_t{4} << 20);
  expect_told_as_in_order("again.csv", again);
}

}  // namespace
