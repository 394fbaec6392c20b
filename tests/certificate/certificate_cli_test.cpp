// `standcal certificate` as an operator runs it: from a state directory, from an imported
// recording, and with the one-line errors of a wrong request.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "calib/diagnosis/diagnosis.hpp"
#include "protocol/jsonrpc/exit_codes.hpp"
#include "tests/certificate/certificate_support.hpp"
#include "tests/certificate/html_query.hpp"
#include "tests/support/command.hpp"
#include "tests/support/unit_static_recording.hpp"

namespace standcal::test {
namespace {

using CommandResult = test::CommandOutcome;

CommandResult run_cli(const std::string& args) { return test::standcal_cli(args); }

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CertificateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    run_dir_ = write_done_run(state_.path(), "20261121T223638Z-AU-0042",
                              simulated_recording("AU-0042", default_truth(), 11, "paper9", 4));
    write_text(state_.file("limits.json"),
               R"({"format": "standcal-limits/1", "unit_types": {"QA-2000": {
        "parameters": {"bias": {"max_abs": 100}, "scale": {"max_abs": 300}, "gamma": {"max_abs": 60}}}}})");
  }
  TempDir state_;
  std::filesystem::path run_dir_;
};

TEST_F(CertificateCli, WritesTheCertificateOfARunInTheStateDirectory) {
  const std::filesystem::path out = state_.file("cert.html");
  const CommandResult r =
      run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --limits " +
              state_.file("limits.json") + " -o " + out.string());
  EXPECT_NE(r.output.find("certificate for AU-0042 written to"), std::string::npos) << r.output;
  const HtmlDocument page(read_text(out));
  // The verdict is the exit status a bench script acts on (README "Exit status").
  const std::string verdict = page.text("//*[@id='verdict']/@data-outcome");
  EXPECT_EQ(r.exit_code, verdict == "fail" ? exit_status(ExitCode::verdict_fail)
                                           : exit_status(ExitCode::verdict_indeterminate))
      << verdict << ": " << r.output;
  EXPECT_EQ(page.text("//dl[@id='traceability']/dd[@data-field='unit_type']"), "QA-2000")
      << "the only unit type in the limits applies";
  // default_truth's scale_z is 310 ppm against a 300 ppm limit: outside by more than U?
  // Either fail or indeterminate, never pass; and the verdict follows the worst.
  EXPECT_NE(page.text("//tr[@data-parameter='scale_z']/@data-outcome"), "pass");
  EXPECT_NE(page.text("//*[@id='verdict']/@data-outcome"), "pass");
  EXPECT_EQ(page.text("//tr[@data-parameter='bias_x']/@data-outcome"), "pass")
      << "45 ug against 100 ug";
}

// Issue 20: with --budget the certificate carries the GUM budget, and the results' U and
// the decision use its expanded uncertainty, not 2 sigma of the fit.
TEST_F(CertificateCli, TheBudgetsExpandedUncertaintyIsTheOneTheDecisionUses) {
  write_text(state_.file("budget.json"), R"({"format": "standcal-budget/1",
      "stand": {"source": "TS-2 data sheet", "angle_zero_arcsec": 10, "level_arcsec": 20, "mounting_arcsec": 120},
      "gravity": {"standard_uncertainty_mps2": 5e-5, "source": "survey"},
      "unit_types": {"QA-2000": {"bias_ug_per_c": 1, "scale_ppm_per_c": 0.5}}})");
  const std::filesystem::path out = state_.file("cert.html");
  const CommandResult r =
      run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --limits " +
              state_.file("limits.json") + " --budget " + state_.file("budget.json") + " -o " +
              out.string());
  const HtmlDocument page(read_text(out));
  ASSERT_EQ(page.count("//table[@id='budget']"), 1u) << r.output;
  // Type A, 2 + 2 + 3 stand rows, gravity, 6 temperature coefficients, then u_c, nu, k, U.
  EXPECT_EQ(page.count("//table[@id='budget']//tr[@data-row='type-b']"), 14u);
  EXPECT_EQ(page.count("//table[@id='budget-inputs']//tr"), 15u);
  EXPECT_EQ(page.text("//ul[@id='not-budgeted']/li"),
            "stand.orthogonality_arcsec (not in the budget file)");
  // scale_x: the U of the results is the budget's, and larger than 2 sigma of the fit alone
  // (u(g)/g = 5 ppm is in it).
  const std::vector<std::string> expanded =
      page.texts("//table[@id='budget']//tr[@data-row='expanded']/td");
  ASSERT_EQ(expanded.size(), 9u);
  const std::string results_u =
      page.text("//tr[@data-parameter='scale_x']/td[contains(@class,'U')]");
  const double budget_u = std::stod(expanded[3]);
  EXPECT_NEAR(std::stod(results_u.substr(results_u.find(' ') + 1)), budget_u, 0.006) << results_u;
  const double type_a =
      std::stod(page.texts("//table[@id='budget']//tr[@data-row='type-a']/td")[3]);
  EXPECT_GT(budget_u, 2 * std::hypot(type_a, 5e-5 / 9.81 * 1e6) * 0.95);
  const std::string why =
      page.text("//tr[@data-parameter='scale_x']/td[contains(@class,'explanation')]");
  ASSERT_NE(why.find("with U = "), std::string::npos) << why;
  EXPECT_NEAR(std::stod(why.substr(why.find("with U = ") + 9)), budget_u, 0.006) << why;
  EXPECT_NE(page.text("//*[@id='rule']").find("combined standard uncertainty"), std::string::npos);
}

// Issue 20, item 2: the issuing laboratory, a certificate number, the signature block, and a
// PDF on A4 whose text a reader (poppler's pdftotext) finds: the number on every page.
class CertificatePdf : public CertificateCli {
 protected:
  void SetUp() override {
    CertificateCli::SetUp();
    write_text(state_.file("lab.json"),
               R"({"format": "standcal-lab/1", "name": "Inertial Test Laboratory",
        "address": "1 Gyro Road, Navtown", "accreditation": "Accredited calibration laboratory D-K-12345-01-00",
        "certificate_prefix": "ITL", "signatories": [{"name": "Ada Example", "role": "Head of laboratory"},
        {"name": "Bob Example", "role": "Calibration engineer"}]})");
  }
  static bool have(const char* tool) {
    return test::run_command(std::string("command -v ") + tool + " >/dev/null").exit_code == 0;
  }
};

TEST_F(CertificatePdf, TheHtmlNamesTheLabTheNumberAndWhoSigns) {
  const std::filesystem::path out = state_.file("cert.html");
  const CommandResult r =
      run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --lab " +
              state_.file("lab.json") + " -o " + out.string());
  const HtmlDocument page(read_text(out));
  EXPECT_EQ(page.text("//header[@id='lab']/p[@class='lab-name']"), "Inertial Test Laboratory")
      << r.output;
  EXPECT_EQ(page.text("//header[@id='lab']/p[@class='lab-accreditation']"),
            "Accredited calibration laboratory D-K-12345-01-00");
  const std::string number = page.text("//*[@id='certificate-number']");
  EXPECT_TRUE(std::regex_match(number, std::regex("ITL-20[0-9]{6}-[0-9]{6}-AU-0042"))) << number;
  EXPECT_NE(r.output.find("certificate number " + number + "\n"), std::string::npos) << r.output;
  EXPECT_EQ(page.count("//table[@id='signatures']//tr[@data-status='not-signed']"), 2u);
  EXPECT_EQ(page.text("//table[@id='signatures']//tr[2]/td[2]"), "Head of laboratory");
  const std::vector<std::string> ids = page.texts("//@id");
  EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()).size(), ids.size()) << "duplicate ids";

  const CommandResult given =
      run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() +
              " --certificate-number ITL/2026/0117 -o " + out.string());
  EXPECT_EQ(HtmlDocument(read_text(out)).text("//*[@id='certificate-number']"), "ITL/2026/0117")
      << given.output;
  EXPECT_NE(HtmlDocument(read_text(out)).text("//header[@id='lab']").find("not configured"),
            std::string::npos);
}

TEST_F(CertificatePdf, RendersAnA4PdfWhoseTextHasTheNumberOnEveryPage) {
  if (!have("weasyprint") || !have("pdftotext")) {
    GTEST_SKIP() << "needs weasyprint and poppler-utils (scripts/setup.sh installs them)";
  }
  const std::filesystem::path out = state_.file("cert.pdf");
  const CommandResult r =
      run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --lab " +
              state_.file("lab.json") + " --limits " + state_.file("limits.json") +
              " --certificate-number ITL/2026/0117 -o " + out.string());
  ASSERT_TRUE(std::filesystem::exists(out)) << r.output;
  EXPECT_EQ(read_text(out).rfind("%PDF-", 0), 0u);
  const CommandResult info = test::run_command("pdfinfo " + out.string());
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("(A4)"), std::string::npos) << info.output;
  std::smatch pages;
  ASSERT_TRUE(std::regex_search(info.output, pages, std::regex("Pages:\\s+([0-9]+)")))
      << info.output;
  const int n = std::stoi(pages[1]);
  EXPECT_GE(n, 2);
  EXPECT_LE(n, 12);
  const CommandResult text = test::run_command("pdftotext -layout " + out.string() + " -");
  ASSERT_EQ(text.exit_code, 0) << text.output;
  for (const std::string& expected :
       {std::string("Inertial Test Laboratory"), std::string("AU-0042"), std::string("Ada Example"),
        std::string("not signed"),
        std::string("page " + std::to_string(n) + " of " + std::to_string(n))}) {
    EXPECT_NE(text.output.find(expected), std::string::npos) << expected;
  }
  std::size_t footers = 0;
  for (std::size_t at = text.output.find("ITL/2026/0117"); at != std::string::npos;
       at = text.output.find("ITL/2026/0117", at + 1))
    ++footers;
  EXPECT_GE(footers, static_cast<std::size_t>(n)) << "the number in every page's footer";
}

TEST_F(CertificateCli, CertifiesAnImportedRecording) {
  const std::filesystem::path out = state_.file("imported.html");
  const CommandResult r = run_cli("certificate --recording " +
                                  (run_dir_ / "recording.csv").string() + " -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const HtmlDocument page(read_text(out));
  EXPECT_EQ(page.text("//dl[@id='traceability']/dd[@data-field='unit_serial']"), "AU-0042");
  EXPECT_EQ(page.count("//figure//svg"), 2u);
}

// The certificate's fits take the wander the unit's static recording pins, as `standcal fit`
// does, its noise paragraph says so, and --diagnose tests against it; a wander given beside it
// is refused.
TEST_F(CertificateCli, TakesTheWanderTheUnitsStaticRecordingPins) {
  const std::string still = state_.file("still.csv");
  write_recording(unit_static_recording(7200, 3, 60, 7), still);
  // diagnostic32: orientations enough for the diagnosis to reach its noise step.
  SimulationRequest run;
  run.program = diagnostic32();
  run.truth = default_truth();
  run.seed = 12;
  run.timing.dwell_s = 10;
  run.unit_serial = "AU-0044";
  const std::string recording = state_.file("d32.csv");
  write_recording(simulate_run(run), recording);
  const std::filesystem::path out = state_.file("static.html");
  const CommandResult r =
      run_cli("certificate --recording " + recording + " --unit-static-recording " + still +
              " --diagnose -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const HtmlDocument page(read_text(out));
  const std::string noise = page.text("//p[@id='noise-model']");
  EXPECT_NE(noise.find("the unit's bias wander as its static recording shows it"),
            std::string::npos)
      << noise;
  EXPECT_NE(noise.find("The unit's static recording " + still +
                       " (2 h static) gave its wander: its Allan curves pin a wander of "),
            std::string::npos)
      << noise;
  // --diagnose tests the terms against the same wander.
  const std::string diagnosis = page.text("//div[@id='diagnosis']");
  EXPECT_NE(diagnosis.find("the unit's wander as its static recording shows it"), std::string::npos)
      << diagnosis;
  const CommandResult refused =
      run_cli("certificate --recording " + recording + " --unit-static-recording " + still +
              " --bias-instability-ug 3 -o " + out.string());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("either as a static recording or as --bias-instability-*"),
            std::string::npos)
      << refused.output;
}

// The certificate of a daemon run says what standcald's unit.static_recording gave the run
// (its header), as `standcal run result` does, and advises on the run's own wander as beside a
// static recording: not by the unit.bias_instability_* the daemon refuses beside it.
TEST_F(CertificateCli, SaysWhatTheDaemonsStaticRecordingGaveItsRun) {
  TruthModel wandering = default_truth();
  wandering.noise.bias_instability_ug = 60;
  wandering.noise.bias_instability_tau_s = 60;
  Recording rec = simulated_recording("AU-0045", wandering, 6, "classic24", 10);
  const std::string gave =
      "the unit's static recording /lab/AU-0045-still.csv (2 h static) gave its curves, to "
      "bound the wander: its Allan curves (to 1995 s) show no wander";
  rec.set_header(kHeaderUnitWanderSource, gave);
  write_done_run(state_.path(), "20261122T080000Z-AU-0045", std::move(rec));
  const std::filesystem::path out = state_.file("daemon-static.html");
  const CommandResult r = run_cli("certificate 20261122T080000Z-AU-0045 --state-dir " +
                                  state_.path() + " -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string noise = HtmlDocument(read_text(out)).text("//p[@id='noise-model']");
  EXPECT_NE(noise.find("Its run, by standcald's unit.static_recording: " + gave), std::string::npos)
      << noise;
  // The run shows a wander of its own, whose correlation time it leaves open.
  ASSERT_NE(noise.find("give the unit's correlation time"), std::string::npos) << noise;
  EXPECT_NE(noise.find("as a static recording of the unit whose Allan curves pin it"),
            std::string::npos)
      << noise;
  EXPECT_EQ(noise.find("unit.bias_instability_tau_s"), std::string::npos) << noise;
  // The certificate's own wander given in place of the header's: the run's line is not what the
  // uncertainties rest on, and is not printed.
  const CommandResult given =
      run_cli("certificate 20261122T080000Z-AU-0045 --state-dir " + state_.path() +
              " --bias-instability-ug 60 -o " + out.string());
  ASSERT_EQ(given.exit_code, 0) << given.output;
  const std::string own = HtmlDocument(read_text(out)).text("//p[@id='noise-model']");
  EXPECT_EQ(own.find("by standcald's unit.static_recording"), std::string::npos) << own;
}

TEST_F(CertificateCli, ExplainsAWrongRequestInOneLine) {
  const std::string out = state_.file("x.html");
  CommandResult r = run_cli("certificate 20990101T000000Z-NO-SUCH-RUN --state-dir " +
                            state_.path() + " -o " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("no run 20990101T000000Z-NO-SUCH-RUN in"), std::string::npos) << r.output;
  r = run_cli("certificate NO-SUCH-RUN --state-dir " + state_.path() + " -o " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("'NO-SUCH-RUN' is not a run id"), std::string::npos) << r.output;

  r = run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --limits " +
              state_.file("limits.json") + " --unit-type QA-9 -o " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("no limits for unit type 'QA-9' (known: QA-2000)"), std::string::npos)
      << r.output;

  write_text(state_.file("lab.json"),
             R"({"format": "standcal-lab/1", "name": "Lab", "signatories": [{"name": "A"}]})");
  r = run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " --lab " +
              state_.file("lab.json") + " -o " + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(state_.file("lab.json") + ": signatories[0].role: missing"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out)) << "nothing written on error";
  r = run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() +
              " --certificate-number 'A B' -o " + out);
  EXPECT_EQ(r.exit_code, 2) << r.output;  // a usage error, refused by the option's check
  EXPECT_NE(r.output.find("1 to 64 letters, digits"), std::string::npos) << r.output;

  r = run_cli("certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path() + " -o " +
              state_.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(state_.path() + ": is a directory"), std::string::npos) << r.output;
}

// "-" and a device or pipe get the page written into them; a rename over /dev/stdout
// would have replaced the device node instead (and failed without root).
TEST_F(CertificateCli, WritesToStandardOutputAndIntoAPipe) {
  const std::string run = "certificate 20261121T223638Z-AU-0042 --state-dir " + state_.path();
  for (const char* target : {"-", "/dev/stdout"}) {
    const CommandResult r = run_cli(run + " -o " + target);
    ASSERT_EQ(r.exit_code, 0) << target << ": " << r.output;
    EXPECT_NE(r.output.find("<html"), std::string::npos) << target;
    EXPECT_NE(r.output.find("certificate for AU-0042 written to"), std::string::npos) << target;
  }
  const std::string fifo = state_.file("cert.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const CommandResult r = run_cli(run + " -o " + fifo + " & cat " + fifo + "; wait $!");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("<html"), std::string::npos) << r.output.substr(0, 300);
  struct stat st {};
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the pipe is still a pipe";
}

// A run id used to be joined to STATE/runs as given, so "../../runs/ID" certified a run of
// another state directory (any folder holding a run.json). A run id is a name, never a path.
TEST_F(CertificateCli, ARunIdThatIsAPathIsRefusedAndNothingOutsideTheStateDirIsRead) {
  const std::filesystem::path lab = state_.path() / std::filesystem::path("lab/state");
  std::filesystem::create_directories(lab / "runs");
  const std::filesystem::path out = state_.file("outside.html");
  const CommandResult r =
      run_cli("certificate ../../../runs/20261121T223638Z-AU-0042 --state-dir " + lab.string() +
              " -o " + out.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("'../../../runs/20261121T223638Z-AU-0042' is not a run id"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out))
      << "a certificate was written from outside the state directory";
}

}  // namespace
}  // namespace standcal::test
