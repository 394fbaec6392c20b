// The offline CLI as a user runs it: real process, real files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "calib/allan.hpp"
#include "calib/raw_input.hpp"
#include "tests/calib/test_support.hpp"
#include "tests/support/command.hpp"

namespace fs = std::filesystem;

namespace {

using CliRun = standcal::test::CommandOutcome;

CliRun run_cli(const std::string& args) { return standcal::test::standcal_cli(args); }

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("standcal_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  // The simulator's default model as a model file takes it (`simulate --truth`), to edit.
  nlohmann::json default_model() const {
    const CliRun r = run_cli("simulate --program paper9 -o " + path("default_model_run.csv") +
                             " --truth " + path("default_model.json"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    nlohmann::json model;
    std::ifstream(path("default_model.json")) >> model;
    return model;
  }
  // One position held `dwell_s` at 10 Hz, the default unit with a 3 ug wander of `tau_s`:
  // a static recording, `<name>.csv`.
  std::string static_recording(const std::string& name, double dwell_s, double tau_s, int seed,
                               double wander_ug = 3) const {
    nlohmann::json truth = default_model();
    truth["noise"]["bias_instability_ug"] = wander_ug;
    truth["noise"]["bias_instability_tau_s"] = tau_s;
    std::ofstream(path(name + "_model.json")) << truth.dump(2);
    std::ofstream(path(name + ".json"))
        << nlohmann::json{{"name", name},
                          {"positions",
                           {{{"alpha1_deg", 0}, {"alpha2_deg", 0}, {"dwell_s", dwell_s}}}}}
               .dump();
    const CliRun r = run_cli("simulate --program " + path(name + ".json") +
                             " --rate-hz 10 --seed " + std::to_string(seed) + " -o " +
                             path(name + ".csv") + " --model " + path(name + "_model.json"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return path(name + ".csv");
  }
  // 18 orientations (outer every 60 deg, inner 0, 45 and 90), 10 s each at 25 Hz, seed 6:
  // enough for the norm fit of the samples without their angles; `<name>.csv`.
  std::string tumble_recording(const std::string& name, const std::string& model_args) const {
    nlohmann::json positions = nlohmann::json::array();
    for (int outer = 0; outer < 360; outer += 60)
      for (int inner : {0, 45, 90})
        positions.push_back({{"alpha1_deg", outer}, {"alpha2_deg", inner}, {"dwell_s", 10}});
    std::ofstream(path("tumble.json"))
        << nlohmann::json{{"name", "tumble"}, {"positions", positions}};
    const CliRun r = run_cli("simulate --program " + path("tumble.json") +
                             " --rate-hz 25 --seed 6 -o " + path(name + ".csv") + model_args);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return path(name + ".csv");
  }
  fs::path dir_;
};

// A command refused, with `words` in what it says.
void expect_refused(const CliRun& run, const std::string& words) {
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find(words), std::string::npos) << words << "\n" << run.output;
}

// The cells of one line of a recording (comma-separated).
std::vector<std::string> csv_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t at = 0;
  for (std::size_t comma; (comma = line.find(',', at)) != std::string::npos; at = comma + 1)
    cells.push_back(line.substr(at, comma - at));
  cells.push_back(line.substr(at));
  return cells;
}

TEST_F(Cli, SimulateThenFitJsonHasTheStableShape) {
  ASSERT_EQ(run_cli("simulate --program paper9 --seed 5 --dwell-s 10 -o " + path("r.csv") +
                    " --truth " + path("t.json"))
                .exit_code,
            0);
  const CliRun fit = run_cli("fit " + path("r.csv") + " --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["estimator"], "joint");
  EXPECT_EQ(j["positions"], 9);
  EXPECT_EQ(j["redundancy"], 0);
  EXPECT_TRUE(j["chi2_dof"].is_null());
  EXPECT_TRUE(j["residual_rms_ug"].is_number());
  for (const char* name : {"bias_x", "bias_y", "bias_z", "scale_x", "scale_y", "scale_z", "gamma12",
                           "gamma13", "gamma23"}) {
    EXPECT_TRUE(j["parameters"][name]["value"].is_number()) << name;
    EXPECT_TRUE(j["parameters"][name]["sigma"].is_number()) << name;
  }
  EXPECT_EQ(j["parameters"]["bias_x"]["unit"], "ug");
  EXPECT_EQ(j["parameters"]["scale_z"]["unit"], "ppm");
  EXPECT_EQ(j["parameters"]["gamma13"]["unit"], "arcsec");
  // The truth file holds what the simulator used, and re-simulating it is identical.
  ASSERT_EQ(run_cli("simulate --program paper9 --seed 5 --dwell-s 10 -o " + path("r2.csv") +
                    " --model " + path("t.json"))
                .exit_code,
            0);
  std::ifstream a(path("r.csv")), b(path("r2.csv"));
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}),
            std::string(std::istreambuf_iterator<char>(b), {}));
}

TEST_F(Cli, ClassicProgrammeReportsGammaAsNullWithAReason) {
  ASSERT_EQ(run_cli("simulate --program classic24 --dwell-s 2 -o " + path("c.csv")).exit_code, 0);
  const CliRun fit = run_cli("fit " + path("c.csv") + " --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_TRUE(j["parameters"]["gamma12"]["value"].is_null());
  EXPECT_NE(j["parameters"]["gamma12"]["unobservable_reason"].get<std::string>().find("u_x*u_y"),
            std::string::npos);
  EXPECT_EQ(j["redundancy"], 18);
}

TEST_F(Cli, TextReportSaysWhatABenchEngineerNeeds) {
  ASSERT_EQ(run_cli("simulate --program paper9 --dwell-s 5 -o " + path("r.csv")).exit_code, 0);
  const CliRun fit =
      run_cli("fit " + path("r.csv") + " --method paper-sequential --compensation " + path("comp"));
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  EXPECT_NE(fit.output.find("Estimator:  paper-sequential"), std::string::npos);
  EXPECT_NE(fit.output.find("Zero redundancy"), std::string::npos);
  EXPECT_NE(fit.output.find("gamma13"), std::string::npos);
  const auto comp = nlohmann::json::parse(std::ifstream(path("comp.json")));
  EXPECT_EQ(comp["equation"], "f = M * (raw - b)");
  EXPECT_EQ(comp["calibration"]["estimator"], "paper-sequential");
  EXPECT_EQ(comp["calibration"]["source"], path("r.csv"));
  EXPECT_EQ(comp["matrix"]["rows"].size(), 3u);
  EXPECT_TRUE(fs::exists(path("comp.csv")));
}

TEST_F(Cli, BadRecordingFailsNamingLineAndWritesNothing) {
  std::ofstream(path("bad.csv"))
      << "# format: standcal-recording/1\n"
         "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg,fx_mps2,fy_mps2,fz_mps2\n"
         "0,0,0,0,0,9.8,0\n"
         "0.01,0,0,0,0,nine,0\n";
  const CliRun fit = run_cli("fit " + path("bad.csv") + " --compensation " + path("comp"));
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(fit.output.find("bad.csv:4: column 6: column 'fy_mps2': 'nine' is not a number"),
            std::string::npos)
      << fit.output;
  EXPECT_FALSE(fs::exists(path("comp.json")));
}

TEST_F(Cli, UnknownProgrammeAndMethodAreClearErrors) {
  const CliRun sim = run_cli("simulate --program paper10 -o " + path("x.csv"));
  EXPECT_NE(sim.exit_code, 0);
  EXPECT_NE(sim.output.find("paper10: not a built-in programme"), std::string::npos) << sim.output;
  EXPECT_FALSE(fs::exists(path("x.csv")));
  ASSERT_EQ(run_cli("simulate --dwell-s 1 -o " + path("r.csv")).exit_code, 0);
  const CliRun fit = run_cli("fit " + path("r.csv") + " --method magic");
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(fit.output.find("--method: magic not in {auto,joint,paper-sequential,full,norm}"),
            std::string::npos)
      << fit.output;
}

TEST_F(Cli, FullVectorFitAddsStandHealth) {
  ASSERT_EQ(run_cli("simulate --program paper9 --dwell-s 10 -o " + path("r.csv")).exit_code, 0);
  const CliRun fit = run_cli("fit " + path("r.csv") + " --method full --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["estimator"], "full");
  EXPECT_TRUE(j["parameters"]["gamma13"]["value"].is_number());
  ASSERT_TRUE(j.contains("stand"));
  EXPECT_FALSE(j["stand"].empty());
}

// Issue 21: `design compare --bias-instability-ug` proposes revisiting the positions; the
// plan becomes a programme file the tools and the daemon run.
TEST_F(Cli, ARevisitPlanIsWrittenAsAProgrammeTheToolsReadBack) {
  const CliRun planned = run_cli(
      "design evaluate paper9 --repeat 4 --dwell-s 19.2 --bias-instability-ug 3 --json -o " +
      path("p.json"));
  ASSERT_EQ(planned.exit_code, 0) << planned.output;
  const nlohmann::json plan = nlohmann::json::parse(planned.output);
  EXPECT_EQ(plan["positions"], 36);
  const CliRun reread =
      run_cli("design evaluate " + path("p.json") + " --bias-instability-ug 3 --json");
  ASSERT_EQ(reread.exit_code, 0) << reread.output;
  const nlohmann::json again = nlohmann::json::parse(reread.output);
  EXPECT_EQ(again["program"], "paper9 x4");
  EXPECT_EQ(again["dwell_s"], plan["dwell_s"]);
  EXPECT_DOUBLE_EQ(again["bench_time"]["total_s"].get<double>(),
                   plan["bench_time"]["total_s"].get<double>());
  EXPECT_DOUBLE_EQ(again["parameters"]["gamma13"]["sigma"].get<double>(),
                   plan["parameters"]["gamma13"]["sigma"].get<double>());
  EXPECT_EQ(
      run_cli("simulate --program " + path("p.json") + " --seed 3 -o " + path("r.csv")).exit_code,
      0);
}

// `design --unit-static-recording`: the unit's noise as its static recording shows it (the
// default unit's 10 ug/sqrt(Hz) and a 3 ug wander of 60 s over two hours), in place of the
// figures, which are refused beside it; a recording that shows no wander is white noise's, one
// that sees a wander it does not pin is refused.
TEST_F(Cli, DesignTakesTheNoiseTheUnitsStaticRecordingShows) {
  const std::string pinned = static_recording("pinned", 7200, 60, 7);
  const CliRun ev = run_cli("design evaluate paper9 --unit-static-recording " + pinned + " --json");
  ASSERT_EQ(ev.exit_code, 0) << ev.output;
  const auto j = nlohmann::json::parse(ev.output.substr(ev.output.find('{')));
  // The white noise fitted beside the wander: the curves read at 1 s gave 13.4 (the wander's).
  EXPECT_NEAR(j["noise_density_ug_rthz"].get<double>(), 10, 0.7) << j.dump(2);
  EXPECT_NEAR(j["bias_instability_ug"].get<double>(), 3, 1.2);
  EXPECT_LT(j["bias_instability_tau_s"].get<double>(), 60 * 1.5);
  EXPECT_GT(j["bias_instability_tau_max_s"].get<double>(), 60 / 1.5);
  EXPECT_NE(j["noise_from"].get<std::string>().find("the unit's static recording " + pinned +
                                                    " (2 h static): white noise "),
            std::string::npos)
      << j["noise_from"];
  EXPECT_EQ(j["noise_from_warnings"], nlohmann::json::array()) << j["noise_from_warnings"];
  const CliRun noise = run_cli("noise " + pinned);
  EXPECT_NE(noise.output.find("the wander below raises the noise density read at 1 s; the white "
                              "noise fitted beside it is x "),
            std::string::npos)
      << noise.output;
  // Its reader's warnings are in the JSON beside noise_from (a last line cut off mid-write).
  const std::string still_file = static_recording("still", 7200, 300, 4, 0);
  std::ofstream(still_file, std::ios::app) << "7200.05,0";
  const CliRun still =
      run_cli("design compare paper9 --unit-static-recording " + still_file + " --json");
  ASSERT_EQ(still.exit_code, 0) << still.output;
  const auto w = nlohmann::json::parse(still.output.substr(still.output.find('{')));
  EXPECT_EQ(w["bias_instability_ug"].get<double>(), 0) << w["noise_from"];
  EXPECT_NE(w["noise_from"].get<std::string>().find("no wander: its Allan curves"),
            std::string::npos)
      << w["noise_from"];
  ASSERT_EQ(w["noise_from_warnings"].size(), 1u) << w["noise_from_warnings"];
  EXPECT_EQ(w["noise_from_warnings"][0].get<std::string>().rfind(still_file + ":", 0), 0u)
      << w["noise_from_warnings"];
  // Half an hour of a 32 ug wander of 300 s: seen, not pinned; white noise would promise too much.
  expect_refused(run_cli("design evaluate paper9 --unit-static-recording " +
                         static_recording("seen", 1800, 300, 13, 31.6)),
                 "see a wander they do not pin");
  const CliRun both = run_cli("design evaluate paper9 --unit-static-recording " + pinned +
                              " --bias-instability-ug 3");
  EXPECT_EQ(both.exit_code, 2) << both.output;
  for (const char* option : {"--unit-static-recording", "--bias-instability-ug", " excludes "})
    EXPECT_NE(both.output.find(option), std::string::npos) << option << "\n" << both.output;
}

// A unit serial with a newline would inject a header line ("# mount: y") into the
// recording: the recording writer refuses it, naming the key, and nothing is written.
TEST_F(Cli, SimulateRefusesAUnitSerialThatWouldInjectAHeaderLine) {
  const CliRun run = run_cli(
      "simulate --program paper9 --dwell-s 1 --unit-serial \"$(printf 'AU\\n# mount: y')\" -o " +
      path("r.csv"));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("recording header 'unit_serial'"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(path("r.csv")));
}

// Dwell and settle times past the daemon's run limits are refused before simulating.
TEST_F(Cli, SimulateRefusesDwellAndSettleTimesPastTheRunLimits) {
  CliRun run = run_cli("simulate --program paper9 --dwell-s 1e9 -o " + path("r.csv"));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("36000"), std::string::npos) << run.output;
  run = run_cli("simulate --program paper9 --settle-s 1e9 -o " + path("r.csv"));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("3600"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(path("r.csv")));
}

// `standcal noise` of a long static recording names the unit's correlation time (the Allan
// curves' Gauss-Markov fit) and how to give it to the fits; the floor's averaging time
// (about 1.9 tau) is not it.
TEST_F(Cli, NoiseOfAStaticRecordingNamesTheCorrelationTimeToGiveTheFits) {
  const std::string eight_hours = static_recording("static", 28800, 300, 2);
  const CliRun json_run = run_cli("noise " + eight_hours + " --json");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
  const auto gm = nlohmann::json::parse(json_run.output)["gauss_markov"];
  ASSERT_TRUE(gm.is_object()) << json_run.output;
  EXPECT_EQ(gm["tau_bounded"], true) << gm.dump(2);
  EXPECT_NEAR(gm["tau_s"].get<double>() / 300, 1, 0.5) << gm.dump(2);
  EXPECT_LT(gm["tau_max_s"].get<double>() / gm["tau_min_s"].get<double>(), 4) << gm.dump(2);
  for (const char* axis : {"x", "y", "z"}) {
    EXPECT_NEAR(gm["axes"][axis]["noise_density_ug_rthz"].get<double>(), 10, 1) << axis;
    const double q_ug = gm["axes"][axis]["q_ug"].get<double>();
    EXPECT_NEAR(q_ug, 3, 1.5) << axis;
    // The sizes the recording allows: around the fitted one, and for eight hours of a 300 s
    // wander bounded and narrow (1.34x wide in the median, bench/noise allan-tau).
    const double lo = gm["axes"][axis]["q_min_ug"].get<double>();
    const double hi = gm["axes"][axis]["q_max_ug"].get<double>();
    EXPECT_LT(lo, q_ug) << axis;
    EXPECT_GT(hi, q_ug) << axis;
    EXPECT_LT(hi / lo, 2) << axis;
  }
  const CliRun text = run_cli("noise " + eight_hours);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  // The unit's wander to give the fits: the largest axis's size, and the range of times.
  double q_max_ug = 0;
  for (const char* axis : {"x", "y", "z"})
    q_max_ug = std::max(q_max_ug, gm["axes"][axis]["q_ug"].get<double>());
  char command[200];
  std::snprintf(command, sizeof command,
                "standcal fit --bias-instability-ug %.3g --bias-instability-tau-s %.0f "
                "--bias-instability-tau-max-s %.0f",
                q_max_ug, gm["tau_min_s"].get<double>(), gm["tau_max_s"].get<double>());
  EXPECT_NE(text.output.find(command), std::string::npos) << command << "\n" << text.output;
  EXPECT_NE(text.output.find("the size is the largest axis's, which this recording allows at "),
            std::string::npos)
      << text.output;
  // Or the recording itself, whose curves give each axis its own size.
  EXPECT_NE(text.output.find("or give this recording itself, which weighs each axis with its own "
                             "size: standcal fit RECORDING --unit-static-recording " +
                             eight_hours),
            std::string::npos)
      << text.output;
  EXPECT_EQ(gm["wander_seen"], true);
  EXPECT_GT(gm["wander_deviance"].get<double>(), kGaussMarkovWanderDeviance) << gm.dump(2);
  // Half an hour of a 1200 s wander: the curves end before it turns over, and the range is
  // open upwards (no tau_max_s to copy, no command to give).
  const std::string half_hour = static_recording("short", 1800, 1200, 1);
  const CliRun open_json = run_cli("noise " + half_hour + " --json");
  ASSERT_EQ(open_json.exit_code, 0) << open_json.output;
  const auto open = nlohmann::json::parse(open_json.output)["gauss_markov"];
  EXPECT_EQ(open["tau_bounded"], false) << open.dump(2);
  EXPECT_TRUE(open["tau_max_s"].is_null()) << open.dump(2);
  const CliRun open_text = run_cli("noise " + half_hour);
  EXPECT_NE(open_text.output.find("correlation time not pinned"), std::string::npos)
      << open_text.output;
  EXPECT_NE(open_text.output.find(" s and beyond (its curves end at"), std::string::npos)
      << open_text.output;
  EXPECT_EQ(open_text.output.find("--bias-instability-tau-max-s"), std::string::npos)
      << open_text.output;
  // Two hours of a 10 ug wander of 1200 s (seed 5): a range bounded at 306-1523 s, but the
  // curves end at 1995 s, before the slowest of it turns over (its Allan peak near 1.9 x it).
  // No size to give (the one they give is the middle's), but the floor the fits take from the
  // recording itself; until 2026-12-07 the size and range were advised.
  const std::string two_hours = static_recording("slow", 7200, 1200, 5, 10);
  const CliRun slow_json = run_cli("noise " + two_hours + " --json");
  ASSERT_EQ(slow_json.exit_code, 0) << slow_json.output;
  const auto slow = nlohmann::json::parse(slow_json.output)["gauss_markov"];
  ASSERT_EQ(slow["tau_bounded"], true) << slow.dump(2);
  ASSERT_GT(slow["tau_max_s"].get<double>() * 1.89, 1995) << slow.dump(2);
  EXPECT_EQ(slow["tau_floor_s"], slow["tau_min_s"]) << slow.dump(2);
  EXPECT_EQ(gm["tau_floor_s"], 0) << "pinned: no floor";
  const CliRun slow_text = run_cli("noise " + two_hours);
  EXPECT_NE(slow_text.output.find(" s), not pinned: its curves end before the slowest of those "
                                  "turns over"),
            std::string::npos)
      << slow_text.output;
  EXPECT_EQ(slow_text.output.find("--bias-instability-tau-max-s"), std::string::npos)
      << slow_text.output;
  char floor_words[160];
  std::snprintf(floor_words, sizeof floor_words,
                "the fits take this recording as a floor of %.0f s under the unit's correlation "
                "time: standcal fit RECORDING --unit-static-recording ",
                slow["tau_min_s"].get<double>());
  EXPECT_NE(slow_text.output.find(floor_words), std::string::npos) << slow_text.output;
  EXPECT_NE(slow_text.output.find("standcald: unit.static_recording), where the run shows the "
                                  "wander at those times"),
            std::string::npos)
      << slow_text.output;
}

// `standcal noise` reads what `standcal fit` reads: the same static samples as imu_tk text
// in g, and as counts of a given scale, give the stand recording's noise figures and
// correlation time (the static interval found by the detector, one orientation held). It
// refused every file but standcal's own before ("one column only").
TEST_F(Cli, NoiseReadsImuTkTextInGAndInCounts) {
  static_recording("static", 7200, 60, 4);
  ASSERT_FALSE(HasFailure()) << "the static recording was not simulated";
  // The recording's samples as imu_tk's `t x y z`, in g and in counts of 1e6 per g.
  std::ifstream in(path("static.csv"));
  std::ofstream in_g(path("static_g.txt")), in_counts(path("static_counts.txt"));
  double g_mps2 = 9.80665;
  std::size_t fx = 0;  // the column of fx_mps2 (fy and fz follow it: docs/recording-format.md)
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# g_local_mps2:", 0) == 0) g_mps2 = std::stod(line.substr(15));
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> cells = csv_cells(line);
    if (cells[0] == "t_s") {
      fx = static_cast<std::size_t>(std::find(cells.begin(), cells.end(), "fx_mps2") -
                                    cells.begin());
      continue;
    }
    ASSERT_GT(fx, 0u);
    ASSERT_LT(fx + 2, cells.size()) << line;
    const double t_s = std::stod(cells[0]);
    const double x = std::stod(cells[fx]) / g_mps2, y = std::stod(cells[fx + 1]) / g_mps2,
                 z = std::stod(cells[fx + 2]) / g_mps2;
    char row[160];
    std::snprintf(row, sizeof row, "%.3f %.9f %.9f %.9f\n", t_s, x, y, z);
    in_g << row;
    std::snprintf(row, sizeof row, "%.3f %.0f %.0f %.0f\n", t_s, x * 1e6, y * 1e6, z * 1e6);
    in_counts << row;
  }
  in_g.close();
  in_counts.close();
  const auto gauss_markov = [](const std::string& args) {
    const CliRun r = run_cli("noise " + args + " --json");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const std::size_t json_at = r.output.find('{');
    EXPECT_NE(json_at, std::string::npos) << r.output;
    return nlohmann::json::parse(json_at == std::string::npos ? "{}" : r.output.substr(json_at));
  };
  const auto stand = gauss_markov(path("static.csv"))["gauss_markov"];
  const auto text_g = gauss_markov(path("static_g.txt"));
  const auto counts =
      gauss_markov(path("static_counts.txt") + " --units counts --counts-per-g 1e6");
  EXPECT_TRUE(stand["tau_bounded"].get<bool>()) << stand.dump(2);
  EXPECT_NE(text_g["static"]["units_how"].get<std::string>().find("g ("), std::string::npos)
      << text_g["static"].dump(2);
  EXPECT_GT(text_g["static"]["longest_s"].get<double>(), 7100) << text_g["static"].dump(2);
  for (const auto* read : {&text_g, &counts}) {
    const auto& gm = (*read)["gauss_markov"];
    EXPECT_EQ(gm["tau_bounded"], true) << gm.dump(2);
    EXPECT_NEAR(gm["tau_s"].get<double>() / stand["tau_s"].get<double>(), 1, 0.1) << gm.dump(2);
    for (const char* axis : {"x", "y", "z"}) {
      const auto& a = gm["axes"][axis];
      const auto& s = stand["axes"][axis];
      EXPECT_NEAR(
          a["noise_density_ug_rthz"].get<double>() / s["noise_density_ug_rthz"].get<double>(), 1,
          0.01)
          << axis;
      EXPECT_NEAR(a["q_ug"].get<double>() / s["q_ug"].get<double>(), 1, 0.1) << axis;
    }
  }
  // Counts of one orientation have no scale the norm fit could find; a scale is for counts.
  CliRun refused = run_cli("noise " + path("static_counts.txt") + " --units counts");
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("--counts-per-g"), std::string::npos) << refused.output;
  refused = run_cli("noise " + path("static_g.txt") + " --counts-per-g 4000");
  EXPECT_EQ(refused.exit_code, 2) << refused.output;  // a usage error, as on a stand recording
  EXPECT_EQ(run_cli("noise " + path("static.csv") + " --counts-per-g 4000").exit_code, 2);
  EXPECT_NE(refused.output.find("read as g"), std::string::npos) << refused.output;
}

// A static recording with gaps in its samples (those of each second's last quarter dropped: what
// standcald's dwells held before its chunks continued each other, or a logger that drops):
// its Allan curves take the samples as evenly spaced and show a shorter correlation time
// (28-55 s here, for a wander of 60 s), so `standcal noise` says what is missing and gives the
// fits no wander, whether the recording is standcal's (its dwell) or another tool's text (its
// static interval found by the detector). Before, both gave the fits that range, unwarned.
TEST_F(Cli, NoiseOfARecordingWithGapsGivesTheFitsNoWander) {
  std::ifstream whole(static_recording("whole", 7200, 60, 4));
  ASSERT_FALSE(HasFailure()) << "the static recording was not simulated";
  std::ofstream gapped(path("gapped.csv")), text_g(path("gapped_g.txt"));
  double g_mps2 = 9.80665, first_s = -1;
  std::size_t fx = 0;  // the column of fx_mps2 (fy and fz follow it: docs/recording-format.md)
  for (std::string line; std::getline(whole, line);) {
    if (line.rfind("# g_local_mps2:", 0) == 0) g_mps2 = std::stod(line.substr(15));
    const std::vector<std::string> cells = csv_cells(line);
    if (line.empty() || line[0] == '#' || cells[0] == "t_s") {
      if (!cells.empty() && cells[0] == "t_s")
        fx = static_cast<std::size_t>(std::find(cells.begin(), cells.end(), "fx_mps2") -
                                      cells.begin());
      gapped << line << "\n";
      continue;
    }
    ASSERT_GT(fx, 0u);
    ASSERT_LT(fx + 2, cells.size()) << line;
    const double t_s = std::stod(cells[0]);
    if (first_s < 0) first_s = t_s;
    if (std::fmod(t_s - first_s, 1.0) >= 0.75) continue;
    gapped << line << "\n";
    char row[160];
    std::snprintf(row, sizeof row, "%.3f %.9f %.9f %.9f\n", t_s, std::stod(cells[fx]) / g_mps2,
                  std::stod(cells[fx + 1]) / g_mps2, std::stod(cells[fx + 2]) / g_mps2);
    text_g << row;
  }
  gapped.close();
  text_g.close();
  const std::string advice = "--bias-instability-tau-max-s";
  ASSERT_NE(run_cli("noise " + path("whole.csv")).output.find(advice), std::string::npos);
  for (const std::string& file : {path("gapped.csv"), path("gapped_g.txt")}) {
    const CliRun text = run_cli("noise " + file);
    ASSERT_EQ(text.exit_code, 0) << text.output;
    EXPECT_NE(text.output.find("samples miss"), std::string::npos) << file << text.output;
    EXPECT_NE(text.output.find("the static samples' time stamps and their sample periods disagree"),
              std::string::npos)
        << file << text.output;
    EXPECT_EQ(text.output.find(advice), std::string::npos) << file << text.output;
    const CliRun json_run = run_cli("noise " + file + " --json");
    ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
    const auto gaps =
        nlohmann::json::parse(json_run.output.substr(json_run.output.find('{')))["gaps"];
    EXPECT_EQ(gaps["too_much"], true) << file << gaps.dump(2);
    EXPECT_GT(gaps["missing_share"].get<double>(), 0.1) << file << gaps.dump(2);
  }
  // A rate given lower than the stamps' (5 Hz for 10) had hidden the gaps: the steps at its
  // period claim more time than the stamps span, and the time missing read as none.
  const std::string slow = "noise " + path("gapped_g.txt") + " --rate-hz 5";
  const CliRun text = run_cli(slow);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("more than their time stamps span"), std::string::npos) << text.output;
  EXPECT_EQ(text.output.find(advice), std::string::npos) << text.output;
  const CliRun json_run = run_cli(slow + " --json");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
  const auto gaps =
      nlohmann::json::parse(json_run.output.substr(json_run.output.find('{')))["gaps"];
  EXPECT_EQ(gaps["too_much"], true) << gaps.dump(2);
  EXPECT_GT(gaps["beyond_stamps_s"].get<double>(), 0.1 * gaps["spanned_s"].get<double>())
      << gaps.dump(2);
}

// A unit whose output filter correlates its samples (a model file's noise.output_filter_tau_s):
// the fit widens each dwell mean's standard error and says so, in the JSON and the report.
TEST_F(Cli, AFitSaysTheSamplesAreCorrelatedAndByHowMuchItWidenedTheDwellErrors) {
  nlohmann::json truth = default_model();
  truth["noise"]["output_filter_tau_s"] = 0.08;  // two sample periods at 25 Hz
  std::ofstream(path("filtered.json")) << truth.dump(2);
  ASSERT_EQ(run_cli("simulate --program paper9 --rate-hz 25 --dwell-s 10 --seed 3 -o " +
                    path("f.csv") + " --model " + path("filtered.json"))
                .exit_code,
            0);
  const CliRun json_run = run_cli("fit " + path("f.csv") + " --json");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
  const auto noise = nlohmann::json::parse(json_run.output)["noise"];
  ASSERT_TRUE(noise["allan"].contains("sample_correlation")) << noise.dump(2);
  for (const auto& f : noise["allan"]["sample_correlation"]["dwell_error_over_sigma_sqrt_n"])
    EXPECT_NEAR(f.get<double>(), 2.02, 0.25) << noise.dump(2);
  const CliRun text = run_cli("fit " + path("f.csv"));
  EXPECT_NE(text.output.find("the samples are correlated over about"), std::string::npos)
      << text.output;
  // A recording of independent samples has none.
  EXPECT_EQ(
      run_cli("fit " + path("default_model_run.csv") + " --json").output.find("sample_correlation"),
      std::string::npos);
}

// imu_tk's Xsens recording, moved by hand: counts read in ug by the norm fit's scale over its
// 39 orientations, and what its curves say told as it is — the samples are correlated over
// about one sample period (the output filter: its Allan deviation lies below white noise's
// line at the first averaging times), which is no bias wander, and the curves depart from
// any white-plus-one-wander model most on z near 3 s. It refused the file before; the Allan
// fit alone called that correlation a wander of 450-530 ug.
TEST_F(Cli, NoiseOfTheXsensRecordingFindsNoBiasWanderAndSaysWhereTheCurvesDepart) {
  const CliRun json_run = run_cli("noise " + standcal::test::kXsens + " --json");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.output;
  const std::size_t json_at = json_run.output.find('{');
  ASSERT_NE(json_at, std::string::npos) << json_run.output;
  const auto j = nlohmann::json::parse(json_run.output.substr(json_at));
  EXPECT_EQ(j["segments"], 39) << j["static"].dump(2);
  EXPECT_NE(j["static"]["units_how"].get<std::string>().find("norm fit's scale over 39"),
            std::string::npos)
      << j["static"].dump(2);
  const auto& gm = j["gauss_markov"];
  EXPECT_EQ(gm["wander_seen"], false) << gm.dump(2);
  EXPECT_EQ(gm["short_correlation"], true) << gm.dump(2);
  EXPECT_LT(gm["tau_max_s"].get<double>(), 0.05) << gm.dump(2);
  EXPECT_EQ(gm["describes_curves"], false) << gm.dump(2);
  EXPECT_EQ(gm["worst_departure"]["axis"], "z") << gm.dump(2);
  for (const char* axis : {"x", "y", "z"}) {
    EXPECT_EQ(gm["axes"][axis]["q_ug"], 0) << axis;
    // The white noise a dwell mean sees, and the Allan curve's own reading at 1 s, agree.
    const double dwell_white = gm["axes"][axis]["noise_density_ug_rthz"].get<double>();
    const double at_one_second = j["axes"][axis]["noise_density_ug_rthz"].get<double>();
    EXPECT_NEAR(dwell_white / at_one_second, 1, 0.1) << axis;
  }
  const CliRun text = run_cli("noise " + standcal::test::kXsens);
  EXPECT_NE(text.output.find("not a bias wander"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("most on z at"), std::string::npos) << text.output;
}

// Issue 21: the fit states the noise model it weighted with — the wander between dwells and
// the Allan figures of the raw samples within them — and weights for a wander that is there.
TEST_F(Cli, FitStatesItsNoiseModelAndWeightsForTheWanderOfTheRun) {
  ASSERT_EQ(run_cli("simulate --program classic24 --seed 3 --dwell-s 10 -o " + path("white.csv") +
                    " --truth " + path("t.json"))
                .exit_code,
            0);
  const CliRun white = run_cli("fit " + path("white.csv") + " --method full --json");
  ASSERT_EQ(white.exit_code, 0) << white.output;
  const auto w = nlohmann::json::parse(white.output)["noise"];
  EXPECT_EQ(w["bias_instability"], false)
      << w.dump(2);  // no wander finding (it may be weighted for)
  // The simulator's white density is 10 ug/rtHz on every axis.
  for (const char* axis : {"x", "y", "z"})
    EXPECT_NEAR(w["allan"]["axes"][axis]["white_density_ug_rthz"].get<double>(), 10.0, 1.5) << axis;
  EXPECT_EQ(w["allan"]["segments"], 24);

  nlohmann::json truth;
  std::ifstream(path("t.json")) >> truth;
  truth["noise"]["bias_instability_ug"] = 30;  // about 10x a 10 s dwell mean's white error
  std::ofstream(path("wander.json")) << truth.dump(2);
  ASSERT_EQ(run_cli("simulate --program classic24 --seed 3 --dwell-s 10 -o " + path("wander.csv") +
                    " --model " + path("wander.json"))
                .exit_code,
            0);
  const CliRun fit = run_cli("fit " + path("wander.csv") + " --method full --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["noise"]["model"], "gauss_markov") << j["noise"].dump(2);
  EXPECT_EQ(j["noise"]["bias_instability"], true);
  EXPECT_EQ(j["noise"]["source"], "estimated");
  const CliRun as_white =
      run_cli("fit " + path("wander.csv") + " --method full --noise white --json");
  ASSERT_EQ(as_white.exit_code, 0) << as_white.output;
  const auto jw = nlohmann::json::parse(as_white.output);
  EXPECT_EQ(jw["noise"]["model"], "white");
  // Weighted for the wander, the biases' sigmas are several times the white ones.
  for (const char* p : {"bias_x", "bias_y", "bias_z"})
    EXPECT_GT(j["parameters"][p]["sigma"].get<double>(),
              3 * jw["parameters"][p]["sigma"].get<double>())
        << p;
  // Estimated, the correlation time comes with the range the run allows; given, it is
  // taken as known and only the wander's size is estimated at it.
  EXPECT_EQ(j["noise"]["tau_given"], false);
  ASSERT_TRUE(j["noise"].contains("tau_plausible_s")) << j["noise"].dump(2);
  EXPECT_LE(j["noise"]["tau_plausible_s"][0].get<double>(), j["noise"]["tau_s"].get<double>());
  EXPECT_GE(j["noise"]["tau_plausible_s"][1].get<double>(), j["noise"]["tau_s"].get<double>());
  const CliRun given =
      run_cli("fit " + path("wander.csv") + " --method full --bias-instability-tau-s 700 --json");
  ASSERT_EQ(given.exit_code, 0) << given.output;
  const auto jg = nlohmann::json::parse(given.output)["noise"];
  EXPECT_EQ(jg["tau_s"], 700.0) << jg.dump(2);
  EXPECT_EQ(jg["tau_given"], true);
  EXPECT_FALSE(jg.contains("tau_plausible_s"));
  EXPECT_NE(jg["how"].get<std::string>().find("at the given correlation time 700 s"),
            std::string::npos)
      << jg["how"];
  const CliRun text =
      run_cli("fit " + path("wander.csv") + " --method full --bias-instability-tau-s 700");
  EXPECT_NE(text.output.find("tau 700 s (given)"), std::string::npos) << text.output;
  // Given as a range (what `standcal noise` says of a static recording), the run weighs the
  // times inside it; a range without its lower end, or upside down, is a usage error.
  const CliRun range = run_cli("fit " + path("wander.csv") +
                               " --method full --bias-instability-tau-s 150 "
                               "--bias-instability-tau-max-s 600 --json");
  ASSERT_EQ(range.exit_code, 0) << range.output;
  const auto jr = nlohmann::json::parse(range.output)["noise"];
  EXPECT_EQ(jr["tau_given"], true) << jr.dump(2);
  EXPECT_EQ(jr["tau_given_s"], nlohmann::json::array({150.0, 600.0}));
  EXPECT_GE(jr["tau_s"].get<double>(), 150 * (1 - 1e-9));
  EXPECT_LE(jr["tau_s"].get<double>(), 600 * (1 + 1e-9));
  EXPECT_NE(jr["how"].get<std::string>().find("the given correlation times 150-600 s"),
            std::string::npos)
      << jr["how"];
  const CliRun range_text = run_cli("fit " + path("wander.csv") +
                                    " --method full --bias-instability-tau-s 150 "
                                    "--bias-instability-tau-max-s 600");
  EXPECT_NE(range_text.output.find("(given as 150-600 s;"), std::string::npos) << range_text.output;
  // A specified wander (the run shows none) with its time given as a range weights at the
  // range's log-middle and averages the biases' variance over the range, each time alike:
  // it is not the range's lower end, where the biases' sigmas would be too small.
  const auto specified = [&](const std::string& tau) {
    const CliRun r = run_cli("fit " + path("white.csv") +
                             " --method full --json --bias-instability-ug 5 " + tau);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return nlohmann::json::parse(r.output);
  };
  const auto over_range =
      specified("--bias-instability-tau-s 150 --bias-instability-tau-max-s 600");
  const auto at_middle = specified("--bias-instability-tau-s 300");
  EXPECT_EQ(over_range["noise"]["source"], "specified") << over_range["noise"].dump(2);
  EXPECT_DOUBLE_EQ(over_range["noise"]["tau_s"].get<double>(), 300);
  EXPECT_EQ(over_range["noise"]["tau_given_s"], nlohmann::json::array({150.0, 600.0}));
  for (const char* p : {"bias_x", "bias_y", "bias_z"})
    EXPECT_GT(over_range["parameters"][p]["sigma"].get<double>(),
              at_middle["parameters"][p]["sigma"].get<double>())
        << p;
  const CliRun no_lower =
      run_cli("fit " + path("wander.csv") + " --bias-instability-tau-max-s 600");
  EXPECT_EQ(no_lower.exit_code, 2) << no_lower.output;
  EXPECT_NE(no_lower.output.find("needs its lower end too: --bias-instability-tau-s"),
            std::string::npos)
      << no_lower.output;
  const CliRun upside_down = run_cli("fit " + path("wander.csv") +
                                     " --bias-instability-tau-s 600 "
                                     "--bias-instability-tau-max-s 150");
  EXPECT_EQ(upside_down.exit_code, 2) << upside_down.output;
  EXPECT_NE(upside_down.output.find("the range is MIN to MAX"), std::string::npos)
      << upside_down.output;
  // A size given without its time leaves the time to the run (the default 300 s is no one's).
  const CliRun size_only =
      run_cli("fit " + path("wander.csv") + " --method full --bias-instability-ug 30 --json");
  ASSERT_EQ(size_only.exit_code, 0) << size_only.output;
  EXPECT_EQ(nlohmann::json::parse(size_only.output)["noise"]["tau_given"], false);
}

// Issue 16: a recording from another tool, without angles, through the same commands.
const std::string& kXsensFile = standcal::test::kXsens;

TEST_F(Cli, FitOfARecordingWithoutAnglesChoosesTheNormFit) {
  const CliRun fit = run_cli("fit " + kXsensFile + " --g-mps2 9.81744 --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["estimator"], "norm");
  EXPECT_EQ(j["input"]["format"], "imu_tk");
  EXPECT_EQ(j["input"]["units"], "counts");
  EXPECT_EQ(j["intervals"]["count"], 39);
  EXPECT_EQ(j["intervals"]["list"].size(), 39u);
  EXPECT_NEAR(j["compensation"]["scale"][0].get<double>(), 414.46, 0.1);
  EXPECT_EQ(j["threshold_stability"].size(), 2u);
  EXPECT_TRUE(j["parameters"]["bias_x"]["value"].is_null());  // counts: no nominal scale
  const CliRun report =
      run_cli("fit " + kXsensFile + " --g-mps2 9.81744 --compensation " + path("comp"));
  ASSERT_EQ(report.exit_code, 0) << report.output;
  EXPECT_NE(report.output.find("Intervals:  39 static"), std::string::npos) << report.output;
  std::ifstream comp(path("comp.json"));
  ASSERT_TRUE(comp.good());
  const auto c = nlohmann::json::parse(comp);
  EXPECT_EQ(c["format"], "standcal-compensation/2");
  EXPECT_EQ(c["raw_units"], "counts");
  EXPECT_EQ(c["matrix"]["rows"].size(), 3u);
  EXPECT_EQ(c["covariance"]["values"].size(), 12u);
  EXPECT_TRUE(fs::exists(path("comp.csv")));
}

// A long static recording that shows no wander: `standcal noise` says the norm fit takes it,
// and `standcal fit --unit-static-recording` weighs its curves, norm and stand fits alike; the
// paper's sequential method and a wander given beside it are refused, naming the option.
TEST_F(Cli, TheNormFitTakesTheUnitsStaticRecording) {
  const std::string still = static_recording("still", 7200, 300, 4, 0);
  const CliRun noise = run_cli("noise " + still);
  ASSERT_EQ(noise.exit_code, 0) << noise.output;
  EXPECT_NE(noise.output.find("the fits take this recording as the unit's: standcal fit RECORDING "
                              "--unit-static-recording " +
                              still + " (any method but paper-sequential"),
            std::string::npos)
      << noise.output;
  // ... and how standcald takes it (its runs' fits weigh it as the command line's do).
  EXPECT_NE(noise.output.find("standcald: unit.static_recording), where it bounds the wander"),
            std::string::npos)
      << noise.output;
  nlohmann::json white = default_model();
  white["noise"]["bias_instability_ug"] = 0;
  std::ofstream(path("white_model.json")) << white.dump(2);
  const std::string cal = tumble_recording("cal", " --model " + path("white_model.json"));
  const CliRun fit =
      run_cli("fit " + cal + " --method norm --unit-static-recording " + still + " --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["unit_static_recording"]["gave"], "bound") << j["unit_static_recording"];
  EXPECT_EQ(j["unit_static_recording"]["source"], still);
  EXPECT_EQ(j["noise"]["sigmas_allowance_allan_curves_from"], "static_recording") << j["noise"];

  // A stand fit takes the curves as the norm fit does: they bound the wander its sigmas allow
  // for, which its report's noise line says.
  const CliRun stand = run_cli("fit " + cal + " --unit-static-recording " + still + " --json");
  ASSERT_EQ(stand.exit_code, 0) << stand.output;
  const auto s = nlohmann::json::parse(stand.output);
  EXPECT_EQ(s["unit_static_recording"]["gave"], "bound") << s["unit_static_recording"];
  EXPECT_NE(s["unit_static_recording"]["why"].get<std::string>().find(
                "show no wander: they bound the wander the sigmas allow for"),
            std::string::npos)
      << s["unit_static_recording"];
  EXPECT_EQ(s["noise"]["sigmas_allowance_allan_curves_from"], "static_recording") << s["noise"];
  const CliRun stand_text = run_cli("fit " + cal + " --unit-static-recording " + still);
  ASSERT_EQ(stand_text.exit_code, 0) << stand_text.output;
  EXPECT_NE(stand_text.output.find("that these dwells and the unit's static recording cannot "
                                   "exclude"),
            std::string::npos)
      << stand_text.output;
  expect_refused(
      run_cli("fit " + cal + " --method paper-sequential --unit-static-recording " + still),
      "--unit-static-recording: the paper-sequential method models no bias wander");
  expect_refused(run_cli("fit " + cal + " --method norm --unit-static-recording " + still +
                         " --bias-instability-ug 3"),
                 "either as a static recording or as --bias-instability-*");
  expect_refused(
      run_cli("fit " + cal + " --method norm --noise white --unit-static-recording " + still),
      "--noise white weighs no wander");
}

// A static recording that pins no wander, beside a run that shows one: the advice is in the
// command's terms (it refuses --bias-instability-* beside the static recording), and the static
// file's reader warnings are in the report and the JSON, stand fit and norm fit alike.
TEST_F(Cli, AStaticRecordingThatPinsNoWanderIsAdvisedOnInTheCommandsTerms) {
  const std::string still = static_recording("still", 7200, 300, 4, 0);
  std::ofstream(still, std::ios::app) << "7200.05,0";  // a last line cut off mid-write
  nlohmann::json wander = default_model();
  wander["noise"]["bias_instability_ug"] = 60;
  wander["noise"]["bias_instability_tau_s"] = 60;
  std::ofstream(path("wander_model.json")) << wander.dump(2);
  const std::string cal = tumble_recording("cal", " --model " + path("wander_model.json"));
  const std::string cut_off = still + ":";
  const CliRun text = run_cli("fit " + cal + " --unit-static-recording " + still);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("the unit's static recording given did not pin one (below)"),
            std::string::npos)
      << text.output;
  EXPECT_EQ(text.output.find("give the unit's, as `standcal noise` measures it"), std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("give the unit's correlation time, as a static recording of the "
                             "unit whose Allan curves pin it"),
            std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("WARNING:    " + cut_off), std::string::npos) << text.output;
  for (const std::string method : {"joint", "norm"}) {
    const CliRun json = run_cli("fit " + cal + " --method " + method + " --unit-static-recording " +
                                still + " --json");
    ASSERT_EQ(json.exit_code, 0) << json.output;
    const auto u =
        nlohmann::json::parse(json.output.substr(json.output.find('{')))["unit_static_recording"];
    ASSERT_EQ(u["warnings"].size(), 1u) << method << u;
    const std::string warning = u["warnings"][0].get<std::string>();
    EXPECT_EQ(warning.rfind(cut_off, 0), 0u) << method << u;
    EXPECT_NE(warning.find("last line has no newline"), std::string::npos) << method << u;
    // Its curves show no wander, but the run shows one of its own: they bounded nothing, which
    // the stand fit says after it is made as the norm fit does.
    EXPECT_EQ(u["gave"], "nothing") << method << u;
    EXPECT_NE(
        u["why"].get<std::string>().find(std::string(method == "norm" ? "intervals" : "dwells") +
                                         " show a wander of their own, weighted for"),
        std::string::npos)
        << method << u;
  }
}

// A static recording that pins the unit's wander gives it to a stand fit as the unit's
// (noise.unit_wander_from "static_recording"), as `standcal noise` would advise it: two hours
// of a 3 ug wander of 60 s.
TEST_F(Cli, AStandFitTakesTheWanderTheUnitsStaticRecordingPins) {
  const std::string pinned = static_recording("pinned", 7200, 60, 7);
  ASSERT_EQ(
      run_cli("simulate --program paper9 --dwell-s 10 --seed 8 -o " + path("run.csv")).exit_code,
      0);
  const CliRun fit =
      run_cli("fit " + path("run.csv") + " --unit-static-recording " + pinned + " --json");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const auto j = nlohmann::json::parse(fit.output);
  EXPECT_EQ(j["unit_static_recording"]["gave"], "wander") << j["unit_static_recording"];
  EXPECT_EQ(j["noise"]["unit_wander_from"], "static_recording") << j["noise"];
  EXPECT_EQ(j["noise"]["tau_given"], true) << j["noise"];
  const CliRun text = run_cli("fit " + path("run.csv") + " --unit-static-recording " + pinned);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("the unit's bias wander as its static recording shows it"),
            std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("(2 h static) gave its wander: its Allan curves pin a wander of "),
            std::string::npos)
      << text.output;
}

// The unit's static recording is its own file, perhaps of another logger than the run's: every
// command that takes it reads it by its own input options (--unit-static-*), never the run's,
// and the reader's messages name those. Here the same two hours as headerless `x,y,z` rows,
// which need their sample rate given.
TEST_F(Cli, EveryCommandReadsTheUnitsStaticRecordingByItsOwnInputOptions) {
  const std::string pinned = static_recording("pinned", 7200, 60, 7);
  const standcal::RawInput samples = standcal::read_input(pinned);
  const std::string rows = path("rows.csv");
  {
    std::ofstream out(rows);
    out.precision(17);
    for (std::size_t i = 0; i < samples.size(); ++i)
      out << samples.axis[0][i] << ',' << samples.axis[1][i] << ',' << samples.axis[2][i] << '\n';
  }
  const std::string run = tumble_recording("run", "");  // orientations for the norm fit too
  const std::string rate = " --unit-static-rate-hz 10";

  // `standcal noise`, which reads them by its own options, advises giving them so.
  const CliRun noise = run_cli("noise " + rows + " --rate-hz 10");
  ASSERT_EQ(noise.exit_code, 0) << noise.output;
  EXPECT_NE(noise.output.find("--unit-static-recording " + rows + rate + " (standcald: " +
                              "unit.static_recording with unit.static_recording_input " +
                              "{\"rate_hz\":10.0})"),
            std::string::npos)
      << noise.output;

  // The run's --rate-hz is the run's: the rows are not read by it.
  const CliRun unread = run_cli("fit " + run + " --rate-hz 10 --unit-static-recording " + rows);
  EXPECT_NE(unread.exit_code, 0) << unread.output;
  EXPECT_NE(unread.output.find(rows), std::string::npos) << unread.output;
  EXPECT_NE(unread.output.find("pass --unit-static-rate-hz with the sample rate"),
            std::string::npos)
      << unread.output;

  // Read by their own options, the rows give what the recording gives.
  const CliRun from_recording =
      run_cli("fit " + run + " --unit-static-recording " + pinned + " --json");
  const CliRun from_rows =
      run_cli("fit " + run + " --unit-static-recording " + rows + rate + " --json");
  ASSERT_EQ(from_recording.exit_code, 0) << from_recording.output;
  ASSERT_EQ(from_rows.exit_code, 0) << from_rows.output;
  const auto r = nlohmann::json::parse(from_recording.output);
  // No "assuming standard gravity" for rows without a g: the fit puts them in ug by the run's.
  const auto j = nlohmann::json::parse(from_rows.output);
  EXPECT_EQ(j["unit_static_recording"]["gave"], "wander") << j["unit_static_recording"];
  EXPECT_EQ(j["parameters"], r["parameters"]);
  EXPECT_EQ(j["noise"]["wander_ug"], r["noise"]["wander_ug"]) << j["noise"];

  // The same options, and the same reading, in every other command that takes the recording.
  const std::vector<std::string> commands = {
      "fit " + run + " --method norm",
      "diagnose " + run,
      "design evaluate paper9",
      "certificate --recording " + run + " -o " + path("c.html"),
      "import " + run + " --db " + path("r.db"),
  };
  for (const std::string& command : commands) {
    const CliRun refused = run_cli(command + " --unit-static-recording " + rows);
    EXPECT_NE(refused.exit_code, 0) << command << "\n" << refused.output;
    EXPECT_NE(refused.output.find("--unit-static-rate-hz"), std::string::npos) << command << "\n"
                                                                               << refused.output;
    const CliRun read = run_cli(command + " --unit-static-recording " + rows + rate);
    EXPECT_EQ(read.exit_code, 0) << command << "\n" << read.output;
  }
  // The reading options belong to the static recording: alone, they are refused.
  expect_refused(run_cli("fit " + run + rate),
                 "--unit-static-rate-hz requires --unit-static-recording");
}

// `diagnose --unit-static-recording` tests the terms against the wander the static recording
// pins, a stand recording and the same samples without their angles alike; it is refused
// beside --bias-instability-*.
TEST_F(Cli, DiagnoseTestsAgainstTheWanderTheUnitsStaticRecordingPins) {
  const std::string pinned = static_recording("pinned", 7200, 60, 7);
  const std::string cal = tumble_recording("cal", "");
  // The same samples without the stand's angles: time and the three axes.
  std::ifstream in(cal);
  std::ofstream raw(path("raw.csv"));
  raw << "t_s,fx_mps2,fy_mps2,fz_mps2\n";
  bool header_seen = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (!header_seen) {
      header_seen = true;
      continue;
    }
    const std::vector<std::string> c = csv_cells(line);
    raw << c[0] << "," << c[6] << "," << c[7] << "," << c[8] << "\n";
  }
  raw.close();
  for (const std::string& file : {cal, path("raw.csv")}) {
    const CliRun d = run_cli("diagnose " + file + " --g-mps2 9.81625 --unit-static-recording " +
                             pinned + " --json");
    ASSERT_EQ(d.exit_code == 0 || d.exit_code == 1, true) << d.output;
    const auto j = nlohmann::json::parse(d.output.substr(d.output.find('{')));
    EXPECT_EQ(j["unit_static_recording"]["gave"], "wander") << file << j["unit_static_recording"];
    EXPECT_EQ(j["noise"]["unit_wander_from"], "static_recording") << file << j["noise"];
    const CliRun text =
        run_cli("diagnose " + file + " --g-mps2 9.81625 --unit-static-recording " + pinned);
    EXPECT_NE(text.output.find("the unit's wander as its static recording shows it"),
              std::string::npos)
        << file << text.output;
  }
  // One that shows no wander gives a stand recording's diagnosis nothing: it tests the terms
  // against a wander, and weighs no bound on one (the fits do: "bound").
  const CliRun still = run_cli("diagnose " + cal + " --g-mps2 9.81625 --unit-static-recording " +
                               static_recording("still", 7200, 300, 4, 0) + " --json");
  ASSERT_EQ(still.exit_code == 0 || still.exit_code == 1, true) << still.output;
  const auto s = nlohmann::json::parse(still.output.substr(still.output.find('{')));
  EXPECT_EQ(s["unit_static_recording"]["gave"], "nothing") << s["unit_static_recording"];
  EXPECT_NE(s["unit_static_recording"]["why"].get<std::string>().find(
                "show no wander: the diagnosis tests the terms against a wander they pin, and "
                "weighs no bound"),
            std::string::npos)
      << s["unit_static_recording"];
  // One that sees a wander it does not pin (30 ug, 1200 s) puts a floor under the correlation
  // time, which the diagnosis offers its revisits as the fits do; this run's (white noise) do not
  // show the wander at those times, so it is set aside, and said so.
  const CliRun slow = run_cli("diagnose " + cal + " --g-mps2 9.81625 --unit-static-recording " +
                              static_recording("slow", 7200, 1200, 6, 30) + " --json");
  ASSERT_EQ(slow.exit_code == 0 || slow.exit_code == 1, true) << slow.output;
  const auto f = nlohmann::json::parse(slow.output.substr(slow.output.find('{')));
  EXPECT_EQ(f["unit_static_recording"]["gave"], "nothing") << f["unit_static_recording"];
  const std::string slow_why = f["unit_static_recording"]["why"].get<std::string>();
  EXPECT_NE(slow_why.find("see a wander they do not pin (to 1995 s they do not show it turn over: "
                          "record about 100 x its correlation time): they put its correlation "
                          "time at "),
            std::string::npos)
      << slow_why;
  EXPECT_NE(slow_why.find(" s or longer, a floor the diagnosis set aside: this run's positions do "
                          "not show the wander at those times"),
            std::string::npos)
      << slow_why;
  EXPECT_NE(f["noise"]["how"].get<std::string>().find("is set aside"), std::string::npos)
      << f["noise"];
  // The same samples without their angles: the norm fit's words on the floor, then the
  // diagnosis's own.
  const CliRun slow_raw =
      run_cli("diagnose " + path("raw.csv") + " --g-mps2 9.81625 --unit-static-recording " +
              path("slow.csv") + " --json");
  ASSERT_EQ(slow_raw.exit_code == 0 || slow_raw.exit_code == 1, true) << slow_raw.output;
  const auto r = nlohmann::json::parse(slow_raw.output.substr(slow_raw.output.find('{')));
  const std::string raw_why = r["unit_static_recording"]["why"].get<std::string>();
  EXPECT_NE(raw_why.find(" s or longer, a floor this fit set aside: this run's intervals do not "
                         "show the wander at those times; the diagnosis set that floor aside: "
                         "this run's positions do not show the wander at those times"),
            std::string::npos)
      << raw_why;
  expect_refused(run_cli("diagnose " + cal + " --unit-static-recording " + pinned +
                         " --bias-instability-ug 3"),
                 "either as a static recording or as --bias-instability-*");
}

TEST_F(Cli, AStandMethodOnARecordingWithoutAnglesIsAClearError) {
  const CliRun fit = run_cli("fit " + kXsensFile + " --method joint");
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(
      fit.output.find(
          "the joint method needs the stand's angles, and this imu_tk recording has none; use "
          "--method norm"),
      std::string::npos)
      << fit.output;
}

TEST_F(Cli, DiagnoseOfARecordingWithoutAnglesFindsNoiseNotPhysics) {
  const CliRun d = run_cli("diagnose " + kXsensFile + " --g-mps2 9.81744 --json");
  ASSERT_EQ(d.exit_code, 0) << d.output;
  const auto j = nlohmann::json::parse(d.output);
  EXPECT_EQ(j["method"], "norm");
  EXPECT_EQ(j["verdict"], "consistent");
  EXPECT_TRUE(j["findings"].empty());
  EXPECT_EQ(j["noise"]["bias_instability"], true);
}

TEST_F(Cli, IntegersThatCouldBeAnyUnitAskForUnits) {
  std::ofstream(path("small.txt")) << "0 0 1\n1 0 0\n0 1 0\n0 0 -1\n";
  const CliRun fit = run_cli("fit " + path("small.txt") + " --rate-hz 100");
  EXPECT_NE(fit.exit_code, 0);
  EXPECT_NE(fit.output.find("pass --units counts|g|mps2"), std::string::npos) << fit.output;
}

// Names from another tool's file need not be UTF-8: `noise --json` of a file named in
// Latin-1 ("\xd6l.csv") and `fit --json` of one whose column name holds a Latin-1 byte printed
// only "[json.exception.type_error.316] invalid UTF-8 byte" (the raw_input fuzz target,
// 2026-12-05). The JSON is printed, the byte written as U+FFFD.
TEST_F(Cli, JsonOfALatin1NameIsPrinted) {
  if (!std::ofstream(path("\xd6l.csv")))  // e.g. a filesystem that takes UTF-8 names only
    GTEST_SKIP() << "this filesystem refuses a file name with the byte 0xD6";
  ASSERT_EQ(run_cli("simulate --program paper9 --dwell-s 10 -o " + path("\xd6l.csv")).exit_code, 0);
  const CliRun noise = run_cli("noise --json " + path("\xd6l.csv"));
  ASSERT_EQ(noise.exit_code, 0) << noise.output;
  EXPECT_NE(nlohmann::json::parse(noise.output)["recording"].get<std::string>().find("\ufffdl.csv"),
            std::string::npos)
      << noise.output;
  // Twelve dwells on a spiral over the sphere, 1 g each; the units are told from the column
  // names, which the JSON states, one of them with a Latin-1 byte.
  {
    std::ofstream rows(path("column.csv"));
    rows << "t_s,pos,fx_mps2,fy_mps2,fz_mps2\xd6\n";
    for (int pose = 0; pose < 12; ++pose) {
      const double z = 1 - (2 * pose + 1) / 12.0, r = std::sqrt(1 - z * z), phi = 2.4 * pose;
      for (int i = 0; i < 4; ++i)
        rows << pose * 5 + i << "," << pose << "," << 9.81 * r * std::cos(phi) + 1e-4 * i << ","
             << 9.81 * r * std::sin(phi) << "," << 9.81 * z + 2e-3 << "\n";
    }
  }
  const CliRun fit = run_cli("fit --json --columns 3,4,5 --g-mps2 9.81 " + path("column.csv"));
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  EXPECT_NE(fit.output.find("fz_mps2\ufffd"), std::string::npos) << fit.output;
  EXPECT_NO_THROW((void)nlohmann::json::parse(fit.output)) << fit.output;
}

// A full disk (/dev/full: every write fails with ENOSPC) is an error naming the file. The
// outputs went through std::ofstream, checked before it closed: a text shorter than its
// buffer was written only at the close, unchecked, so `noise --curve /dev/full` exited 0
// (a longer one, like the model file, failed at the check). Now every output goes through
// write_file_atomically. (--compensation takes a stem, FILE.json and FILE.csv: not a device.)
TEST_F(Cli, AFullDiskIsAnErrorForEveryOutput) {
  ASSERT_EQ(
      run_cli("simulate --program paper9 --seed 5 --dwell-s 10 -o " + path("r.csv")).exit_code, 0);
  const std::vector<std::pair<std::string, std::string>> outputs{
      {"simulate --program paper9 --seed 5 --dwell-s 10 -o " + path("s.csv") + " --truth /dev/full",
       "/dev/full: could not write the model file (write: No space left on device)"},
      {"simulate --program paper9 --seed 5 --dwell-s 10 -o /dev/full",
       "/dev/full: could not write the recording (write: No space left on device)"},
      {"design optimize --positions 9 --structure paper -o /dev/full",
       "/dev/full: could not write the programme (write: No space left on device)"},
      {"noise " + path("r.csv") + " --curve /dev/full",
       "/dev/full: could not write the Allan curve (write: No space left on device)"}};
  for (const auto& [args, message] : outputs) {
    const CliRun r = run_cli(args);
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
  }
}

}  // namespace
