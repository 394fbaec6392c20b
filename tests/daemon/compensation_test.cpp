// Issue 20, item 3: the compensation of a daemon run, with its identity, written with the
// run, exported by `standcal run result --compensation`, and applied to the run's raw
// samples by the C example (tools/apply-compensation) gives gravity's magnitude within the
// uncertainty the file states.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "calib/averaging.hpp"
#include "calib/compensation.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"

using namespace standcal;
using nlohmann::json;
using protocol::Client;
using test::DaemonProcess;
using test::finished;
using test::socket_of;
using test::TempDir;
using test::wait_run;

namespace {

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// paper9's poses twice: the joint fit then has nine measurements more than parameters, so
// the magnitudes it leaves are a test of the compensation and not zero by construction.
json paper9_twice() {
  json positions = json::array();
  for (int round = 0; round < 2; ++round)
    for (const ProgramPosition& p : paper9().positions)
      positions.push_back({{"alpha1_deg", p.alpha1_deg}, {"alpha2_deg", p.alpha2_deg}});
  return {{"name", "paper9-twice"}, {"positions", positions}};
}

// One position's samples calibrated by the C example: their mean, f in m/s^2.
struct Calibrated {
  Vec3 raw_mean = Vec3::Zero();
  Vec3 f_mean = Vec3::Zero();
  double standard_error_mps2 = 0;  // of |f|'s mean, from the dwell's scatter
};

// Runs `apply_compensation CSV` on every sample of the recording; the means per position.
std::map<int, Calibrated> apply_c_example(const std::string& csv, const Recording& rec,
                                          const std::string& dir) {
  std::ofstream raw(dir + "/raw.txt");
  raw.precision(17);
  for (const RecordingSample& s : rec.samples)
    raw << s.f_mps2.x() << ' ' << s.f_mps2.y() << ' ' << s.f_mps2.z() << '\n';
  raw.close();
  const test::CommandOutcome out = test::run_command(std::string(APPLY_COMPENSATION_PATH) + " " +
                                                     csv + " m/s^2 < " + dir + "/raw.txt");
  EXPECT_EQ(out.exit_code, 0) << out.output;
  std::istringstream lines(out.output);
  std::map<int, std::vector<Vec3>> f_by_pos;
  std::map<int, Vec3> raw_sum;
  for (const RecordingSample& s : rec.samples) {
    Vec3 f;
    lines >> f.x() >> f.y() >> f.z();
    f_by_pos[s.pos].push_back(f);
    raw_sum.try_emplace(s.pos, Vec3::Zero()).first->second += s.f_mps2;
  }
  EXPECT_TRUE(lines.good()) << "fewer output lines than samples";
  std::map<int, Calibrated> means;
  for (const auto& [pos, fs] : f_by_pos) {
    Calibrated& c = means[pos];
    for (const Vec3& f : fs) c.f_mean += f;
    c.f_mean /= static_cast<double>(fs.size());
    c.raw_mean = raw_sum[pos] / static_cast<double>(fs.size());
    double scatter = 0;
    for (const Vec3& f : fs) scatter += std::pow(f.norm() - c.f_mean.norm(), 2);
    c.standard_error_mps2 =
        std::sqrt(scatter / static_cast<double>(fs.size() - 1) / static_cast<double>(fs.size()));
  }
  return means;
}

// The standard uncertainty of |M (raw - b)| that the compensation's covariance implies.
double magnitude_sigma(const Compensation& c, const Vec3& raw) {
  const Vec3 d = raw - c.bias;
  const Vec3 f = c.matrix * d;
  const Vec3 unit = f.normalized();
  Eigen::Matrix<double, kCompensationValues, 1> gradient;
  gradient.head<3>() = -(c.matrix.transpose() * unit);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) gradient[3 + 3 * i + k] = unit[i] * d[k];
  return std::sqrt(gradient.dot(c.covariance * gradient));
}

}  // namespace

TEST(DaemonCompensation, ARunsCompensationAppliedByTheCExampleGivesGravity) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const json started = c.call("run.start", {{"program", paper9_twice()},
                                            {"unit_serial", "AU-0042"},
                                            {"unit_type", "QA-3000"},
                                            {"dwell_s", 30},
                                            {"settle_s", 2}});
  const std::string run_id = started["run_id"];
  ASSERT_EQ(wait_run(c, run_id, finished)["state"], "done") << daemon->log();

  // Written with the run, and the same document in run.result.
  const std::string run_dir = dir.path() + "/state/runs/" + run_id;
  const json result = c.call("run.result", {{"run_id", run_id}});
  ASSERT_TRUE(result.contains("compensation")) << result.dump(2);
  const json stored = json::parse(file_text(run_dir + "/compensation.json"));
  EXPECT_EQ(stored, result["compensation"]);
  const Compensation comp = compensation_from_json(stored);
  EXPECT_EQ(comp.identity.unit_serial, "AU-0042");
  EXPECT_EQ(comp.identity.unit_type, "QA-3000");
  EXPECT_EQ(comp.identity.run_id, run_id);
  EXPECT_EQ(comp.identity.stand_id, "sim-stand");
  EXPECT_EQ(comp.identity.calibrated_utc, result["traceability"]["ended_utc"]);
  EXPECT_EQ(comp.estimator, "joint");
  ASSERT_TRUE(comp.identity.temperature_reference_c.has_value());
  EXPECT_NEAR(*comp.identity.temperature_reference_c, 23, 2);
  EXPECT_GT(comp.covariance(0, 0), 0);
  EXPECT_FALSE(comp.standcal_version.empty());

  // Exported by the CLI: the same JSON and CSV as the daemon's files.
  const test::CommandOutcome exported =
      test::standcal_cli("run result " + run_id + " --socket " + socket_of(dir) +
                         " --compensation " + dir.path() + "/out");
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  EXPECT_EQ(json::parse(file_text(dir.path() + "/out.json")), stored);
  EXPECT_EQ(file_text(dir.path() + "/out.csv"), file_text(run_dir + "/compensation.csv"));

  // The C example on the raw samples: every position's |f| is g within the stated
  // uncertainty (the compensation's, from its covariance, and the dwell mean's).
  const Recording rec = read_recording(result["recording_path"]);
  const std::map<int, Calibrated> means = apply_c_example(dir.path() + "/out.csv", rec, dir.path());
  ASSERT_EQ(means.size(), 18u);
  const double g = result["traceability"]["g_local_mps2"];
  int outside_without_compensation = 0;
  for (const auto& [pos, m] : means) {
    const double u = std::hypot(magnitude_sigma(comp, m.raw_mean), m.standard_error_mps2);
    EXPECT_LT(std::abs(m.f_mean.norm() - g), 3 * u)
        << "position " << pos << ": |f| - g = " << (m.f_mean.norm() - g) / g / kUg
        << " ug, u = " << u / g / kUg << " ug";
    // The bound discriminates: the raw outputs are not gravity within it.
    if (std::abs(m.raw_mean.norm() - g) > 3 * u) ++outside_without_compensation;
  }
  EXPECT_GE(outside_without_compensation, 12);
}

// A damaged file is not loaded: one digit of b changed, and the C example and the reader
// both refuse it by its checksum.
TEST(DaemonCompensation, AnEditedCompensationFailsItsChecksum) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 300);
  Client c(socket_of(dir));
  const json started =
      c.call("run.start",
             {{"program", "paper9"}, {"unit_serial", "AU-1"}, {"dwell_s", 5}, {"settle_s", 1}});
  ASSERT_EQ(wait_run(c, started["run_id"], finished)["state"], "done") << daemon->log();
  const std::string run_dir = dir.path() + "/state/runs/" + started["run_id"].get<std::string>();

  std::string csv = file_text(run_dir + "/compensation.csv");
  const std::size_t b_row = csv.find("\nb,");
  ASSERT_NE(b_row, std::string::npos);
  const std::size_t digit = csv.find_first_of("123456789", b_row + 5);
  csv[digit] = csv[digit] == '9' ? '8' : static_cast<char>(csv[digit] + 1);
  std::ofstream(dir.path() + "/edited.csv") << csv;
  const test::CommandOutcome out = test::run_command(std::string(APPLY_COMPENSATION_PATH) + " " +
                                                     dir.path() + "/edited.csv < /dev/null");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find("edited.csv: checksum"), std::string::npos) << out.output;
  EXPECT_NE(out.output.find("damaged or edited, not loaded"), std::string::npos) << out.output;
  // The right file for other raw units is refused too, before it is applied.
  const test::CommandOutcome units =
      test::run_command(std::string(APPLY_COMPENSATION_PATH) + " " + run_dir +
                        "/compensation.csv counts < /dev/null");
  EXPECT_EQ(units.exit_code, 2);
  EXPECT_NE(units.output.find("is for raw outputs in m/s^2, not counts: not loaded"),
            std::string::npos)
      << units.output;
  // And an output it cannot write is an error, not a silent truncation.
  const test::CommandOutcome full =
      test::run_command("(echo 1 2 3 | " + std::string(APPLY_COMPENSATION_PATH) + " " + run_dir +
                        "/compensation.csv > /dev/full)");
  EXPECT_EQ(full.exit_code, 2);
  EXPECT_NE(full.output.find("stdout: No space left on device"), std::string::npos) << full.output;

  json doc = json::parse(file_text(run_dir + "/compensation.json"));
  doc["bias"]["values"][1] = doc["bias"]["values"][1].get<double>() * 1.001;
  try {
    (void)compensation_from_json(doc);
    ADD_FAILURE() << "an edited bias was accepted";
  } catch (const CompensationError& e) {
    EXPECT_NE(std::string(e.what()).find("checksum: the file says"), std::string::npos) << e.what();
  }
}

// With run.budget configured, a run's result carries the GUM budget of its joint fit: the
// gravity uncertainty given there widens the scale factors' U beyond 2 sigma of the fit.
TEST(DaemonCompensation, ARunWithAConfiguredBudgetCarriesIt) {
  TempDir dir;
  const std::string budget = dir.path() + "/budget.json";
  std::ofstream(budget) << R"({"format": "standcal-budget/1", "stand": {"mounting_arcsec": 120},
      "gravity": {"standard_uncertainty_mps2": 5e-5, "source": "survey"}})";
  const json config = {{"socket", {{"path", socket_of(dir)}}},
                       {"state_dir", dir.path() + "/state"},
                       {"run", {{"budget", budget}}}};
  const std::string file = dir.path() + "/standcald.json";
  std::ofstream(file) << config.dump(2);
  DaemonProcess daemon(dir.path(), {"--config", file, "--sim", "--time-scale", "300"});
  daemon.wait_ready(socket_of(dir));
  Client c(socket_of(dir));
  const json started =
      c.call("run.start",
             {{"program", "paper9"}, {"unit_serial", "AU-9"}, {"dwell_s", 10}, {"settle_s", 1}});
  ASSERT_EQ(wait_run(c, started["run_id"], finished)["state"], "done") << daemon.log();
  const json result = c.call("run.result", {{"run_id", started["run_id"]}});
  ASSERT_TRUE(result.contains("uncertainty_budget")) << result.dump(2);
  const json& scale_x = result["uncertainty_budget"]["parameters"]["scale_x"];
  EXPECT_EQ(result["uncertainty_budget"]["inputs"].size(), 4u);  // mounting about x, y, z; gravity
  const double sigma_ppm = result["parameters"]["scale_x"]["sigma"];
  EXPECT_GT(scale_x["expanded_U"].get<double>(),
            1.9 * std::hypot(sigma_ppm, 5e-5 / 9.81 * 1e6) * 0.99)
      << scale_x.dump(2);
  EXPECT_NE(result["uncertainty_budget"]["not_budgeted"].dump().find("stand.angle_zero_arcsec"),
            std::string::npos);
}
