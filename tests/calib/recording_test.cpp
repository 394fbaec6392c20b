// The recording format's rules (recording-format.md), one test per rule.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include <sys/stat.h>
#include <unistd.h>

#include "calib/noise_model.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"

using namespace standcal;

namespace {

const std::string kHeader =
    "# format: standcal-recording/1\n"
    "# g_local_mps2: 9.81625\n"
    "# settle_s: 5\n"
    "# sample_rate_hz: 100\n"
    "# unit_serial: AU-0042\n";
const std::string kColumns =
    "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,alpha1_deg,alpha2_deg,fx_mps2,fy_mps2,fz_mps2,temp_c\n";
const std::string kRow0 =
    "5.000,0,0.0000,0.0000,0.000012,-0.000210,0.000421,9.816702,-0.000217,23.05\n";
const std::string kRow1 =
    "5.010,0,0.0000,0.0000,0.000012,-0.000210,0.000425,9.816700,-0.000219,23.05\n";
const std::string kRow2 = "20.000,1,90.0000,0.0000,,,9.816702,0.000421,-0.000217,\n";

// The error message of parsing `text`, or "" when it parses.
std::string error_of(const std::string& text) {
  try {
    parse_recording(text, "rec.csv");
  } catch (const RecordingError& e) {
    return e.what();
  }
  return "";
}

// A one-sample recording with `line` as its second header line.
std::string with_header(const std::string& line) {
  return "# format: standcal-recording/1\n" + line + "\n" + kColumns + kRow0;
}

}  // namespace

TEST(RecordingReader, ReadsTheExampleOfTheFormatDocument) {
  const Recording r = parse_recording(kHeader + kColumns + kRow0 + kRow1 + kRow2, "rec.csv");
  ASSERT_EQ(r.samples.size(), 3u);
  EXPECT_DOUBLE_EQ(r.g_local_mps2, 9.81625);
  EXPECT_DOUBLE_EQ(r.settle_s, 5.0);
  EXPECT_EQ(r.unit_serial, "AU-0042");
  EXPECT_DOUBLE_EQ(r.samples[0].f_mps2.y(), 9.816702);
  EXPECT_DOUBLE_EQ(r.samples[0].alpha2_deg, -0.000210);
  EXPECT_TRUE(std::isnan(r.samples[2].alpha1_deg));  // empty optional field
  EXPECT_TRUE(std::isnan(r.samples[2].temp_c));
  EXPECT_TRUE(r.warnings.empty());
}

// A spreadsheet's "CSV UTF-8" starts with a byte order mark; it used to hide the first
// header line and surface as "required column ... is missing".
TEST(RecordingReader, ALeadingUtf8ByteOrderMarkIsSkipped) {
  const Recording r =
      parse_recording("\xEF\xBB\xBF" + kHeader + kColumns + kRow0 + kRow1, "rec.csv");
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.unit_serial, "AU-0042");
  EXPECT_DOUBLE_EQ(r.g_local_mps2, 9.81625);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(RecordingReader, FindsColumnsByNameInAnyOrder) {
  const std::string text = kHeader +
                           "fz_mps2,fy_mps2,fx_mps2,pos,t_s,alpha2_cmd_deg,alpha1_cmd_deg\n" +
                           "3,2,1,0,0.5,20,10\n";
  const Recording r = parse_recording(text, "rec.csv");
  EXPECT_EQ(r.samples[0].f_mps2, Vec3(1, 2, 3));
  EXPECT_DOUBLE_EQ(r.samples[0].alpha1_cmd_deg, 10);
  EXPECT_FALSE(r.columns.temp);
}

TEST(RecordingReader, IntegerAndDecimalHeaderNumbersAreTheSame) {
  const std::string a = "# format: standcal-recording/1\n# g_local_mps2: 9.8\n# settle_s: 5\n";
  const std::string b = "# format: standcal-recording/1\n# g_local_mps2: 9.8\n# settle_s: 5.0\n";
  EXPECT_DOUBLE_EQ(parse_recording(a + kColumns + kRow0, "a").settle_s,
                   parse_recording(b + kColumns + kRow0, "b").settle_s);
}

TEST(RecordingReader, KeepsUnknownHeaderKeysAndIgnoresThem) {
  const Recording r =
      parse_recording(kHeader + "# operator: Ivanova\n" + kColumns + kRow0, "rec.csv");
  EXPECT_EQ(r.header_value("operator"), "Ivanova");
}

TEST(RecordingReader, MissingGravityAssumesStandardWithAWarning) {
  const Recording r =
      parse_recording("# format: standcal-recording/1\n" + kColumns + kRow0, "rec.csv");
  EXPECT_DOUBLE_EQ(r.g_local_mps2, 9.80665);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("9.80665"), std::string::npos);
}

TEST(RecordingReader, TruncatedLastLineIsDroppedWithAWarning) {
  const std::string cut = kRow1.substr(0, 20);  // no newline: a crash mid-write
  const Recording r = parse_recording(kHeader + kColumns + kRow0 + cut, "rec.csv");
  EXPECT_EQ(r.samples.size(), 1u);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("rec.csv:8"), std::string::npos);
  EXPECT_NE(r.warnings[0].find("dropped"), std::string::npos);
}

TEST(RecordingReader, CompleteLastLineWithoutNewlineIsStillDropped) {
  // The rule is about the newline: a line without one may be cut inside a number.
  const std::string row = kRow1.substr(0, kRow1.size() - 1);
  const Recording r = parse_recording(kHeader + kColumns + kRow0 + row, "rec.csv");
  EXPECT_EQ(r.samples.size(), 1u);
  EXPECT_EQ(r.warnings.size(), 1u);
}

TEST(RecordingErrors, MissingFormatHeader) {
  EXPECT_NE(error_of("# g_local_mps2: 9.8\n" + kColumns + kRow0)
                .find("'# format: standcal-recording/1' is missing"),
            std::string::npos);
}

TEST(RecordingErrors, UnsupportedFormat) {
  EXPECT_NE(error_of("# format: other/2\n" + kColumns + kRow0)
                .find("rec.csv:1: unsupported format 'other/2'"),
            std::string::npos);
}

TEST(RecordingErrors, MissingColumnIsNamed) {
  const std::string cols = "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fz_mps2\n";
  EXPECT_NE(error_of(kHeader + cols + "0,0,0,0,1,2\n")
                .find("rec.csv:6: required column 'fy_mps2' is missing"),
            std::string::npos);
}

TEST(RecordingErrors, NonNumberNamesLineAndColumn) {
  const std::string bad =
      "5.020,0,0.0000,0.0000,0.000012,-0.000210,0.000421,9.81x,-0.000217,23.05\n";
  EXPECT_NE(error_of(kHeader + kColumns + kRow0 + bad + kRow2)
                .find("rec.csv:8: column 8: column 'fy_mps2': '9.81x' is not a number"),
            std::string::npos);
}

// A corrupted force field was read as a sample: `standcal noise` then printed a bias
// instability of "inf" and white noise "not seen" on that axis (the raw_input fuzz target,
// 2026-12-04, on a recording without angles; a stand recording the same).
TEST(RecordingErrors, AForceNoAccelerometerGivesNamesLineAndColumn) {
  const std::string exponent =
      "5.020,0,0.0000,0.0000,0.000012,-0.000210,-7.36E161,9.816702,-0.000217,23.05\n";
  const std::string message = error_of(kHeader + kColumns + kRow0 + exponent);
  EXPECT_NE(message.find("rec.csv:8: column 7: column 'fx_mps2': -7.36e+161 is beyond any "
                         "accelerometer's output"),
            std::string::npos)
      << message;
  // Rows after the first whose still columns repeat are read by a quicker path.
  const std::string plain =
      "5.020,0,0.0000,0.0000,0.000012,-0.000210,0.000425,10000000000000.5,-0.000219,23.05\n";
  const std::string quick = error_of(kHeader + kColumns + kRow0 + kRow1 + plain);
  // Said with the digits that show it past the bound: six digits said of 1000000000000.5 "1e+12
  // is beyond ... at most 1e12".
  EXPECT_NE(quick.find("rec.csv:9: column 8: column 'fy_mps2': 1e+13 is beyond"), std::string::npos)
      << quick;
  const std::string just_past =
      "5.020,0,0.0000,0.0000,0.000012,-0.000210,0.000425,1000000000000.5,-0.000219,23.05\n";
  EXPECT_NE(error_of(kHeader + kColumns + kRow0 + kRow1 + just_past)
                .find("column 'fy_mps2': 1000000000000.5 is beyond"),
            std::string::npos);
  const std::string largest =
      "5.020,0,0.0000,0.0000,0.000012,-0.000210,0.000425,-1000000000000,-0.000219,23.05\n";
  EXPECT_EQ(error_of(kHeader + kColumns + kRow0 + kRow1 + largest), "");
}

// A corrupted time, angle or temperature was read as a measurement: one time of 1.7e308 s
// at the end of a paper9 recording without a rate header made `standcal diagnose` call
// every drift untestable and propose no position, and one temperature of 1e300 degC did the
// same to the temperature terms, silently.
TEST(RecordingErrors, ATimeAngleOrTemperatureNoRunHoldsNamesLineAndColumn) {
  const auto row = [](const std::string& t, const std::string& a1, const std::string& temp) {
    return t + ",0,0.0000,0.0000," + a1 + ",-0.000210,0.000425,9.816700,-0.000219," + temp + "\n";
  };
  const std::string ordinary = kHeader + kColumns + kRow0;  // the next row takes the quick path
  EXPECT_NE(error_of(ordinary + row("1.7e308", "0.000012", "23.05"))
                .find("rec.csv:8: column 1: column 't_s': 1.7e+308 s is not a time a recording "
                      "holds (within +-1e12 s)"),
            std::string::npos);
  EXPECT_NE(error_of(ordinary + row("170000000000000", "0.000012", "23.05"))
                .find("rec.csv:8: column 1: column 't_s': 1.7e+14 s is not a time"),
            std::string::npos);
  EXPECT_NE(error_of(ordinary + row("5.020", "0.000012", "1e300"))
                .find("rec.csv:8: column 10: column 'temp_c': 1e+300 degC is not a unit's "
                      "temperature (-273.15 ... 1000 degC)"),
            std::string::npos);
  EXPECT_NE(error_of(ordinary + row("5.020", "0.000012", "-300"))
                .find("rec.csv:8: column 10: column 'temp_c': -300 degC is not"),
            std::string::npos);
  EXPECT_NE(error_of(ordinary + row("5.020", "-2e6", "23.05"))
                .find("rec.csv:8: column 5: column 'alpha1_deg': -2e+06 deg is not a stand angle "
                      "(within +-1e6 deg, 2778 turns)"),
            std::string::npos);
  const std::string commanded = "5.000,0,1e300,0.0000,,,0.000421,9.816702,-0.000217,\n";
  EXPECT_NE(error_of(kHeader + kColumns + commanded)
                .find("rec.csv:7: column 3: column 'alpha1_cmd_deg': 1e+300 deg is not"),
            std::string::npos);
  // The bounds themselves are values a recording may hold.
  EXPECT_EQ(error_of(ordinary + row("1000000000000", "-1000000", "1000")), "");
  EXPECT_EQ(error_of(ordinary + row("5.020", "0.000012", "-273.15")), "");
  const std::string arrival_columns =
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,t_arrive_s\n";
  EXPECT_NE(error_of(kHeader + arrival_columns + "5,0,0,0,0,9.8,0,-1e13\n")
                .find("rec.csv:7: column 8: column 't_arrive_s': -1e+13 s is not a time"),
            std::string::npos);
}

// A header number beyond what it can be: a rate of 1e300 Hz was taken over the rows' times
// (`standcal fit` then gave a sample period of 1e-300 s and no white noise), and a rate of 0
// or below, a negative settling time and a reference temperature of 1e300 degC were read
// without a word.
TEST(RecordingErrors, AHeaderNumberNoRunHoldsNamesItsLine) {
  EXPECT_NE(error_of(with_header("# sample_rate_hz: 1e300"))
                .find("rec.csv:2: header 'sample_rate_hz': 1e300 Hz is not a sample rate (at "
                      "least 1e-12, at most 1e6 Hz)"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# sample_rate_hz: 0")).find("header 'sample_rate_hz': 0 Hz"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# sample_rate_hz: 1e-320"))
                .find("header 'sample_rate_hz': 1e-320 Hz is not a sample rate"),
            std::string::npos);  // a period of infinity
  EXPECT_EQ(error_of(with_header("# sample_rate_hz: 1e-12")), "");
  EXPECT_NE(error_of(with_header("# settle_s: -1"))
                .find("rec.csv:2: header 'settle_s': -1 s is not a settling time (0 ... 1e12 s)"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# temp_ref_c: 1e300"))
                .find("rec.csv:2: header 'temp_ref_c': 1e300 degC is not a temperature a unit "
                      "works at (-273.15 ... 1000 degC)"),
            std::string::npos);
  EXPECT_EQ(error_of(with_header("# sample_rate_hz: 1000000")), "");
  EXPECT_EQ(error_of(with_header("# settle_s: 0")), "");
  EXPECT_NE(error_of(with_header("# warmup_s: -1"))
                .find("rec.csv:2: header 'warmup_s': -1 s is not a warm-up time (0 ... 1e12 s)"),
            std::string::npos);
  EXPECT_DOUBLE_EQ(parse_recording(with_header("# warmup_s: 7200"), "rec.csv").warmup_s, 7200);
}

// The unit's wander a run was made with (standcald's unit.bias_instability_*): read as given,
// and a value the daemon's configuration would refuse is refused naming its line.
TEST(RecordingErrors, TheUnitsWanderItsRunWasMadeWithIsReadOrRefusedByItsLine) {
  const Recording r = parse_recording(
      "# format: standcal-recording/1\n# unit_bias_instability_ug: 2.5\n"
      "# unit_bias_instability_tau_s: 200\n"
      "# unit_bias_instability_tau_max_s: 900\n" +
          kColumns + kRow0,
      "rec.csv");
  EXPECT_DOUBLE_EQ(r.unit_wander.size_ug, 2.5);
  EXPECT_DOUBLE_EQ(r.unit_wander.tau_s, 200);
  EXPECT_DOUBLE_EQ(r.unit_wander.tau_max_s, 900);
  EXPECT_EQ(parse_recording(with_header("# unit_serial: A"), "rec.csv").unit_wander.size_ug, 0);
  EXPECT_NE(error_of(with_header("# unit_bias_instability_ug: -1"))
                .find("rec.csv:2: header 'unit_bias_instability_ug': -1 ug is outside 0 ... "),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# unit_bias_instability_tau_s: many"))
                .find("rec.csv:2: header 'unit_bias_instability_tau_s': 'many' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# unit_bias_instability_tau_max_s: 900"))
                .find("rec.csv:2: header 'unit_bias_instability_tau_max_s': a range needs its "
                      "lower end too: unit_bias_instability_tau_s"),
            std::string::npos);
  EXPECT_NE(error_of("# format: standcal-recording/1\n# unit_bias_instability_tau_s: 900\n"
                     "# unit_bias_instability_tau_max_s: 200\n" +
                     kColumns + kRow0)
                .find("rec.csv:3: header 'unit_bias_instability_tau_max_s': 200 s is below "
                      "unit_bias_instability_tau_s 900 s: the range is MIN to MAX"),
            std::string::npos);
}

// What standcald's static recording gave a run beside a wander: the floor its curves put under
// the correlation time, and its curves themselves, each refused at its line where it is not one
// (the curves' own checks: FitNoise.TheCarriedCurvesRoundTripAndABadOneIsRefusedAtItsLine).
TEST(RecordingErrors, TheStaticRecordingsFloorAndCurvesAreReadOrRefusedByTheirLine) {
  EXPECT_DOUBLE_EQ(parse_recording(with_header("# unit_static_tau_floor_s: 859"), "rec.csv")
                       .unit_static_tau_floor_s,
                   859);
  EXPECT_EQ(parse_recording(with_header("# unit_serial: A"), "rec.csv").unit_static_tau_floor_s, 0);
  EXPECT_NE(error_of(with_header("# unit_static_tau_floor_s: 0.5"))
                .find("rec.csv:2: header 'unit_static_tau_floor_s': 0.5 s is outside 1 ... "),
            std::string::npos)
      << error_of(with_header("# unit_static_tau_floor_s: 0.5"));
  EXPECT_NE(error_of(with_header("# unit_static_allan_curves: {}"))
                .find("rec.csv:2: header 'unit_static_allan_curves': not the Allan curves of a "
                      "static recording: curves_end_s is not a number"),
            std::string::npos)
      << error_of(with_header("# unit_static_allan_curves: {}"));
}

// Each axis's size (a static recording's curves pin one per axis): all three, beside the
// size that is their largest, or refused naming the line.
TEST(RecordingErrors, TheUnitsWanderPerAxisIsReadWithItsLargestOrRefusedByItsLine) {
  const std::string axes =
      "# unit_bias_instability_x_ug: 2\n# unit_bias_instability_y_ug: 4.5\n"
      "# unit_bias_instability_z_ug: 3\n";
  const Recording r = parse_recording("# format: standcal-recording/1\n" + axes +
                                          "# unit_bias_instability_ug: 4.5\n" + kColumns + kRow0,
                                      "rec.csv");
  EXPECT_EQ(r.unit_wander.size_axes_ug, Vec3(2, 4.5, 3));
  EXPECT_DOUBLE_EQ(r.unit_wander.size_ug, 4.5);
  EXPECT_NE(error_of(with_header("# unit_bias_instability_ug: 4.5\n"
                                 "# unit_bias_instability_y_ug: 4.5"))
                .find("rec.csv:3: header 'unit_bias_instability_y_ug': each axis's size comes "
                      "with the others': unit_bias_instability_x_ug, _y_ug and _z_ug"),
            std::string::npos);
  EXPECT_NE(error_of("# format: standcal-recording/1\n" + axes + "# unit_bias_instability_ug: 5\n" +
                     kColumns + kRow0)
                .find("rec.csv:2: header 'unit_bias_instability_x_ug': the largest axis's size, "
                      "4.5 ug, is not unit_bias_instability_ug's 5 ug: that key holds the largest"),
            std::string::npos);
  EXPECT_NE(error_of("# format: standcal-recording/1\n" + axes + kColumns + kRow0)
                .find("rec.csv:2: header 'unit_bias_instability_x_ug': the axes' sizes come "
                      "beside unit_bias_instability_ug, their largest"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# unit_bias_instability_z_ug: -3"))
                .find("rec.csv:2: header 'unit_bias_instability_z_ug': -3 ug is outside 0 ... "),
            std::string::npos);
  // What set_unit_wander_header writes is what is read back.
  GivenWander w;
  w.size_ug = 4.5;
  w.size_axes_ug = Vec3(2, 4.5, 3);
  w.known_tau = KnownTau{40, 90};
  Recording header =
      parse_recording("# format: standcal-recording/1\n" + kColumns + kRow0, "rec.csv");
  set_unit_wander_header(header, w);
  const Recording back = parse_recording(format_recording_header(header) + kRow0, "back.csv");
  EXPECT_EQ(given_wander_of(back.unit_wander).axes_ug(), w.size_axes_ug);
  EXPECT_EQ(given_wander_of(back.unit_wander).specified().q_g, w.size_axes_ug * kUg);
}

// A header in Latin-1 (a serial typed on an old bench PC): `standcal import` stored the
// serial's raw bytes, which every JSON output then printed as U+FFFD (so a serial copied
// from `records --json` found nothing in `history`) and PostgreSQL refused.
TEST(RecordingErrors, AHeaderThatIsNotUtf8NamesItsLineAndByte) {
  EXPECT_NE(error_of(with_header("# unit_serial: M\xFC"
                                 "ller-7"))
                .find("rec.csv:2: column 17: header line is not UTF-8 text: byte 17 is not (save "
                      "the file as UTF-8)"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# program: p\xC3")).find("rec.csv:2: column 13: header line"),
            std::string::npos);  // cut short
  EXPECT_NE(error_of(with_header("# program: \xED\xA0\x80")).find("column 12"),
            std::string::npos);  // a surrogate
  EXPECT_NE(error_of(with_header("# program: \xC0\xAF")).find("column 12"),
            std::string::npos);  // overlong '/'
  EXPECT_NE(error_of(with_header("# program: \xF4\x90\x80\x80")).find("column 12"),
            std::string::npos);  // past U+10FFFF
  EXPECT_EQ(error_of(with_header("# unit_serial: M\xC3\xBCller-7 \xF0\x9F\x94\xA7")), "");
  // A line a spreadsheet quoted and padded: the byte is counted in the line as in the file.
  EXPECT_NE(error_of(with_header("  \"# unit_serial: M\xFC"
                                 "ller, 7\",,,,,,"))
                .find("rec.csv:2: column 20: header line is not UTF-8 text: byte 20 is not"),
            std::string::npos);
  // The writer's check (simulate --unit-serial in Latin-1) and the reader's agree.
  Recording rec;
  rec.set_header("unit_serial",
                 "M\xFC"
                 "ller");
  EXPECT_THROW((void)format_recording_header(rec), std::invalid_argument);
}

// A header line indented, or quoted by a spreadsheet: its errors name the file's column.
// They were counted in the text after its blanks and quotes were taken off (column 13 for
// the tab at the file's column 16 of the first line).
TEST(RecordingErrors, AHeaderLinesErrorNamesTheFilesColumn) {
  EXPECT_NE(error_of(with_header("  \"# program: a\tb\",,,,,,"))
                .find("rec.csv:2: column 16: header line contains the control character U+0009 "
                      "at character 16"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("  # program: a\tb")).find("rec.csv:2: column 15: "),
            std::string::npos);
  EXPECT_NE(error_of(with_header("# program: a\tb")).find("rec.csv:2: column 13: "),
            std::string::npos);
  // A doubled quote is one character of the value but two of the file.
  EXPECT_NE(error_of(with_header("\"# program: \"\"x\"\"\x01\",,,,,,"))
                .find("rec.csv:2: column 18: header line contains the control character U+0001"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("  \"# program: a\"b\",,,,,,"))
                .find("rec.csv:2: column 16: a quote inside a quoted header line"),
            std::string::npos);
  EXPECT_NE(error_of(with_header("  #program: a")).find("rec.csv:2: column 3: header line must"),
            std::string::npos);
}

// The simulator writes its header numbers exactly (std::to_string wrote six decimals: a g
// of 9.8162538712345 m/s^2 as 9.816254), so a simulated file read back holds its own g.
TEST(RecordingWriter, TheSimulatorWritesItsHeaderNumbersExactly) {
  SimulationRequest req;
  req.program = paper9();
  req.timing.dwell_s = 0.1;
  req.timing.settle_s = 0.12345678912345;
  req.truth.g_local_mps2 = 9.8162538712345;
  req.truth.temperature.start_c = 23.123456789012;
  req.truth.extra_physics.push_back({"bias_temperature", "x", 1.0});  // writes temp_ref_c
  const Recording written = simulate_run(req);
  const Recording read = parse_recording(format_recording_header(written), "sim.csv");
  EXPECT_EQ(read.g_local_mps2, 9.8162538712345);
  EXPECT_EQ(read.settle_s, 0.12345678912345);
  ASSERT_TRUE(read.temp_ref_c.has_value());
  EXPECT_EQ(*read.temp_ref_c, 23.123456789012);
}

// The simulator writes only what the reader reads: a model whose temperature profile starts
// at 1e300 degC is refused, naming the column, where it wrote a recording `fit` refused.
TEST(RecordingWriter, TheSimulatorRefusesAModelNoRecordingHolds) {
  SimulationRequest req;
  req.program = paper9();
  req.timing.dwell_s = 0.1;
  req.truth.temperature.start_c = 1e300;
  try {
    (void)simulate_run(req);
    FAIL() << "simulated a temperature of 1e300 degC";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("simulating position 1: the model gives a sample no "
                                          "recording holds: column 'temp_c': 1e+300 degC",
                                          0),
              0u)
        << e.what();
  }
  req.truth.temperature.start_c = 23;
  EXPECT_EQ(simulate_run(req).samples.size(), 90u);
  // A profile whose samples are plausible but whose start, the temp_ref_c header of a model
  // with temperature terms, is not (1004 degC falling 1 degC/s).
  SimulationRequest falling = req;
  falling.truth.temperature = {1004, -3600, 0, 0, 1};
  falling.truth.extra_physics.push_back({"bias_temperature", "x", 1.0});
  EXPECT_THROW(simulate_run(falling), std::runtime_error);
  // The rate is written as it was given (std::to_string wrote 1e-7 Hz as 0.000000).
  SimulationRequest slow = req;
  slow.timing.sample_rate_hz = 1e-7;
  slow.timing.dwell_s = 1e7;
  const Recording one_each = simulate_run(slow);
  EXPECT_EQ(one_each.header_value("sample_rate_hz"), "1e-07");
  EXPECT_EQ(parse_recording(format_recording_header(one_each), "slow.csv").sample_rate_hz, 1e-7);
  req.truth.unit.bias_g.x() = 1e300;  // a force beyond any accelerometer's
  EXPECT_THROW(
      {
        try {
          (void)simulate_run(req);
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("column 'fx_mps2': "), std::string::npos)
              << e.what();
          throw;
        }
      },
      std::runtime_error);
}

TEST(RecordingErrors, TimeGoingBackwards) {
  EXPECT_NE(
      error_of(kHeader + kColumns + kRow1 + kRow0).find("rec.csv:8: column 1: t_s goes backwards"),
      std::string::npos);
}

TEST(RecordingErrors, PositionBlockNotContiguous) {
  const std::string again = "21.000,0,0.0000,0.0000,,,0.1,9.8,0.1,\n";
  EXPECT_NE(error_of(kHeader + kColumns + kRow0 + kRow2 + again)
                .find("rec.csv:9: column 2: position 0 appears again"),
            std::string::npos);
}

TEST(RecordingErrors, WrongFieldCount) {
  EXPECT_NE(error_of(kHeader + kColumns + "5.0,0,0,0\n").find("rec.csv:7: expected 10 fields"),
            std::string::npos);
}

TEST(RecordingErrors, BadPositionIndexApproachMountAndHeaderNumber) {
  EXPECT_NE(error_of(kHeader + kColumns + "5.0,-1,0,0,,,0,9.8,0,\n").find("not a position index"),
            std::string::npos);
  const std::string cols =
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,approach,mount\n";
  EXPECT_NE(error_of(kHeader + cols + "5,0,0,0,0,9.8,0,2,x\n")
                .find("column 8: column 'approach': '2' must be +1 or -1"),
            std::string::npos);
  EXPECT_NE(error_of(kHeader + cols + "5,0,0,0,0,9.8,0,1,w\n")
                .find("column 9: column 'mount': 'w' is not x, y or z"),
            std::string::npos);
  EXPECT_NE(error_of("# format: standcal-recording/1\n# settle_s: five\n" + kColumns + kRow0)
                .find("rec.csv:2: header 'settle_s': 'five' is not a number"),
            std::string::npos);
}

TEST(RecordingErrors, CommandedAngleChangingInsideABlock) {
  const std::string moved = "5.020,0,0.5000,0.0000,,,0.1,9.8,0.1,\n";
  EXPECT_NE(error_of(kHeader + kColumns + kRow0 + moved)
                .find("commanded angles change inside position 0"),
            std::string::npos);
}

TEST(RecordingErrors, HeaderWithoutColumnLine) {
  EXPECT_NE(error_of(kHeader).find("no column-header line"), std::string::npos);
}

TEST(RecordingWriter, RoundTripsASimulatedRunExactlyEnough) {
  SimulationRequest req;
  req.program = classic24();
  req.timing.dwell_s = 0.5;
  const Recording original = simulate_run(req);
  const std::string path =
      (std::filesystem::temp_directory_path() / "standcal_roundtrip.csv").string();
  write_recording(original, path);
  const Recording back = read_recording(path);
  std::filesystem::remove(path);
  ASSERT_EQ(back.samples.size(), original.samples.size());
  EXPECT_TRUE(back.columns.mount && back.columns.approach && back.columns.t_arrive);
  for (std::size_t i = 0; i < back.samples.size(); i += 7) {
    EXPECT_NEAR((back.samples[i].f_mps2 - original.samples[i].f_mps2).norm(), 0, 1e-9);
    EXPECT_EQ(back.samples[i].pos, original.samples[i].pos);
    EXPECT_EQ(back.samples[i].mount, original.samples[i].mount);
    EXPECT_EQ(back.samples[i].approach, original.samples[i].approach);
  }
  EXPECT_EQ(back.unit_serial, original.unit_serial);
  EXPECT_DOUBLE_EQ(back.g_local_mps2, original.g_local_mps2);
}

TEST(RecordingWriter, LeavesNoFileWhenTheDirectoryCannotBeWritten) {
  Recording rec;
  EXPECT_THROW(write_recording(rec, "/nonexistent-dir/rec.csv"), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists("/nonexistent-dir/rec.csv"));
}

// `standcal simulate -o /dev/null` once replaced the machine's /dev/null with a plain file
// (a temporary file renamed over it). A pipe stands in for the device here.
TEST(RecordingWriter, WritesIntoAPipeInsteadOfReplacingIt) {
  SimulationRequest req;
  req.program = paper9();
  req.timing.dwell_s = 0.2;
  const Recording rec = simulate_run(req);
  const auto fifo =
      std::filesystem::temp_directory_path() / ("standcal_fifo_" + std::to_string(::getpid()));
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] {
    std::ifstream in(fifo, std::ios::binary);
    received.assign(std::istreambuf_iterator<char>(in), {});
  });
  write_recording(rec, fifo.string());
  reader.join();
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_EQ(parse_recording(received, "pipe").samples.size(), rec.samples.size());
  std::filesystem::remove(fifo);
}

// A header value is one line of text: a newline would inject a header key ("# mount: y")
// or repeat one (the reader then refuses the whole recording), a NUL ends C strings early.
// The writer refuses them whoever calls it, naming the key.
TEST(RecordingWriter, RefusesControlCharactersInTheHeaderNamingTheKey) {
  const auto error_of_header = [](const std::string& key, const std::string& value) {
    Recording rec;
    rec.set_header(key, value);
    try {
      (void)format_recording_header(rec);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error_of_header("unit_serial", "AU\n# mount: y"),
            "recording header 'unit_serial': the value contains the control character U+000A at "
            "character 3; "
            "header values must be printable text on one line");
  EXPECT_NE(error_of_header("program", std::string("p\0q", 3)).find("'program'"),
            std::string::npos);
  EXPECT_NE(error_of_header("unit_type", "QA\r7").find("U+000D"), std::string::npos);
  EXPECT_NE(error_of_header("unit_type",
                            "QA\xC2\x85"
                            "7")
                .find("U+0085"),
            std::string::npos);
  EXPECT_NE(error_of_header("bad\nkey", "v").find("key"), std::string::npos);
  EXPECT_NE(error_of_header("a: b", "v").find("':'"), std::string::npos);
  EXPECT_EQ(error_of_header("unit_type", "QA-7 \xC3\xA9"), "");  // printable UTF-8 is fine
  EXPECT_EQ(error_of_header("unit_serial", "M\xFCller"),
            "recording header 'unit_serial': byte 2 of the value is not UTF-8 text");
}

namespace {

// Recordings that went through a spreadsheet and back (issue 19): header lines padded
// with the separators of empty cells, quoted cells, and the clear refusal of a ';' file.
const char* const kAsWritten =
    "# format: standcal-recording/1\n"
    "# g_local_mps2: 9.81\n"
    "# stand: lab 2, stand A\n"
    "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,mount\n"
    "0.00,0,0,0,0.01,0.02,9.81,x\n"
    "0.01,0,0,0,0.011,0.021,9.809,x\n"
    "0.02,1,90,0,9.81,0.02,0.01,y\n";

// What LibreOffice writes back when the file is opened and saved as CSV: every line as
// wide as the widest, the cell holding a comma quoted, text cells quoted, trailing zeros
// of numbers gone, and a byte order mark.
const char* const kSpreadsheetSaved =
    "\xEF\xBB\xBF# format: standcal-recording/1,,,,,,,\r\n"
    "# g_local_mps2: 9.81,,,,,,,\r\n"
    "\"# stand: lab 2, stand A\",,,,,,,\r\n"
    "\"t_s\",\"pos\",\"alpha1_cmd_deg\",\"alpha2_cmd_deg\",\"fx_mps2\",\"fy_mps2\",\"fz_mps2\","
    "\"mount\"\r\n"
    "0,0,0,0,0.01,0.02,9.81,\"x\"\r\n"
    "0.01,0,0,0,0.011,0.021,9.809,\"x\"\r\n"
    "0.02,1,90,0,9.81,0.02,0.01,\"y\"\r\n";

TEST(SpreadsheetRecording, ASpreadsheetReSaveReadsAsTheOriginal) {
  const Recording original = parse_recording(kAsWritten, "original.csv");
  const Recording saved = parse_recording(kSpreadsheetSaved, "saved.csv");
  EXPECT_EQ(saved.header_value("stand"), "lab 2, stand A");
  EXPECT_EQ(saved.header_value("format"), original.header_value("format"));
  EXPECT_DOUBLE_EQ(saved.g_local_mps2, 9.81);
  ASSERT_EQ(saved.samples.size(), original.samples.size());
  for (std::size_t i = 0; i < saved.samples.size(); ++i) {
    const RecordingSample& a = original.samples[i];
    const RecordingSample& b = saved.samples[i];
    EXPECT_EQ(a.t_s, b.t_s);
    EXPECT_EQ(a.pos, b.pos);
    EXPECT_EQ(a.alpha1_cmd_deg, b.alpha1_cmd_deg);
    EXPECT_EQ(a.f_mps2, b.f_mps2);
    ASSERT_TRUE(b.mount.has_value());
    EXPECT_EQ(*a.mount, *b.mount);
  }
}

// What the writer writes, the reader reads back: a value that ends in a separator or two is
// not a spreadsheet's padding (which is at least six: a recording has seven columns).
TEST(SpreadsheetRecording, AValueEndingInACommaIsKept) {
  const Recording r = parse_recording(
      "# format: standcal-recording/1\n# operator: Smith, J.;\n# stand: A,,\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2,temp_c\n0,0,0,0,0,0,9.8,"
      "\"\"\n",
      "rec.csv");
  EXPECT_EQ(r.header_value("operator"), "Smith, J.;");
  EXPECT_EQ(r.header_value("stand"), "A,,");
  EXPECT_TRUE(std::isnan(r.samples.at(0).temp_c)) << "a quoted empty cell is an empty cell";
}

// A spreadsheet in a decimal-comma locale writes ';' between cells and ',' in numbers.
TEST(SpreadsheetRecording, ASemicolonFileIsNamedAsSuchWithTheFix) {
  const std::string semicolons =
      "# format: standcal-recording/1;;;;;;\n"
      "# g_local_mps2: 9,81;;;;;;\n"
      "t_s;pos;alpha1_cmd_deg;alpha2_cmd_deg;fx_mps2;fy_mps2;fz_mps2\n"
      "0;0;0;0;0,01;0,02;9,81\n";
  const std::string e = error_of(semicolons);
  EXPECT_NE(e.find("rec.csv:3"), std::string::npos) << e;
  EXPECT_NE(e.find("separated by ';', not ','"), std::string::npos) << e;
  EXPECT_NE(e.find("'.' decimals"), std::string::npos) << e;
}

TEST(SpreadsheetRecording, AQuotedDecimalCommaIsNamedWhereItIs) {
  const std::string text =
      "# format: standcal-recording/1\n# g_local_mps2: 9.81\n"
      "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n"
      "0,0,0,0,\"0,01\",0.02,9.81\n";
  const std::string e = error_of(text);
  EXPECT_NE(e.find("rec.csv:4: expected 7 fields"), std::string::npos) << e;
  EXPECT_NE(e.find("a decimal comma?"), std::string::npos) << e;
}

TEST(SpreadsheetRecording, ATabSeparatedFileIsNamedAsSuch) {
  const std::string e = error_of(
      "# format: "
      "standcal-recording/"
      "1\nt_s\tpos\talpha1_cmd_deg\talpha2_cmd_deg\tfx_mps2\tfy_mps2\tfz_mps2\n0\t0\t0\t0\t0\t0\t9."
      "8\n");
  EXPECT_NE(e.find("separated by tabs"), std::string::npos) << e;
}

}  // namespace
