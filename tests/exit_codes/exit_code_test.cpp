// Exit status as a bench script sees it (README "Exit status", man pages EXIT STATUS).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "protocol/jsonrpc/exit_codes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::test {
namespace {

int code(ExitCode c) { return exit_status(c); }

CommandOutcome standcald(const std::string& args) {
  return run_command(std::string(STANDCALD_PATH) + " " + args);
}

TEST(ExitCodes, UsageErrorsAreTwoWhateverCli11Calls) {
  // CLI11's own codes: 109 (an extra argument), 106 (a required one missing), 105 (a value
  // that is not a number).
  for (const char* args :
       {"no-such-command", "fit", "simulate --program paper9 -o x.csv --rate-hz abc",
        "fit rec.csv --method sideways"}) {
    const CommandOutcome r = standcal_cli(args);
    EXPECT_EQ(r.exit_code, code(ExitCode::usage_error)) << "standcal " << args << ": " << r.output;
  }
  EXPECT_EQ(standcald("--no-such-option").exit_code, code(ExitCode::usage_error));
  EXPECT_EQ(standcal_cli("--help").exit_code, 0);
  EXPECT_EQ(standcal_cli("--help-all").exit_code, 0);
}

// CLI11's PositiveNumber printed its range as "0.000000 to 1797693134862315708..." (309
// digits); the bound is said as a person would.
TEST(ExitCodes, ARangeErrorSaysTheBoundReadably) {
  const CommandOutcome r = standcal_cli("simulate --program paper9 -o x.csv --rate-hz abc");
  EXPECT_EQ(r.exit_code, code(ExitCode::usage_error));
  EXPECT_NE(r.output.find("--rate-hz: 'abc' is not a number"), std::string::npos) << r.output;
  EXPECT_LT(r.output.size(), 200u) << r.output;
  const CommandOutcome negative = standcal_cli("simulate --program paper9 -o x.csv --rate-hz -5");
  EXPECT_NE(negative.output.find("must be >= 1e-12 and <= 1000000 (got -5)"), std::string::npos)
      << negative.output;
  // Past the recording format's largest rate (a recording the readers would refuse).
  const CommandOutcome fast = standcal_cli("simulate --program paper9 -o x.csv --rate-hz 1e7");
  EXPECT_EQ(fast.exit_code, code(ExitCode::usage_error));
  EXPECT_NE(fast.output.find("--rate-hz: must be >= 1e-12 and <= 1000000 (got 1e7)"),
            std::string::npos)
      << fast.output;
  const CommandOutcome dwell = standcal_cli("simulate --program paper9 -o x.csv --dwell-s 0");
  EXPECT_NE(dwell.output.find("--dwell-s: must be > 0 and <= "), std::string::npos) << dwell.output;
}

// A validator's description is appended to the option's type in --help: the UTF-8 check of
// import's text options had it read "--operator TEXT:TEXT", the recordings "TEXT:(TEXT) AND
// (FILE)".
TEST(ExitCodes, HelpSaysEachOptionsTypeOnce) {
  const CommandOutcome help = standcal_cli("import --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_EQ(help.output.find("TEXT:TEXT"), std::string::npos) << help.output;
  EXPECT_EQ(help.output.find("(TEXT)"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("--operator TEXT "), std::string::npos) << help.output;
  // Refused before any file is read (the database would refuse it after the fit).
  const CommandOutcome latin1 = standcal_cli(std::string("import ") + STANDCAL_CLI_PATH +
                                             " --operator 'M\xfc"
                                             "ller'");
  EXPECT_EQ(latin1.exit_code, code(ExitCode::usage_error)) << latin1.output;
  EXPECT_NE(latin1.output.find("--operator: must be UTF-8 text: byte 2 is not"), std::string::npos)
      << latin1.output;
}

// import keeps a recording's full path: run from a directory whose name is not UTF-8, it
// fitted the file and the database then refused the row (exit 1, after any earlier files
// were stored). It is refused before the first fit, as a file name in Latin-1 is.
TEST(ExitCodes, ImportFromADirectoryNamedInLatin1IsRefusedBeforeAnyFit) {
  TempDir dir;
  const std::string latin1 = dir.file("st\xf6nd");
  std::filesystem::create_directory(latin1);
  std::ofstream(latin1 + "/rec.csv") << "not read\n";
  const CommandOutcome r = run_command("cd '" + latin1 + "' && " + STANDCAL_CLI_PATH +
                                       " import rec.csv --db sqlite://" + dir.file("lab.sqlite"));
  EXPECT_EQ(r.exit_code, code(ExitCode::usage_error)) << r.output;
  // The 0xF6 of "/st\xf6nd", in the directory as the kernel names it (TMPDIR may be a link).
  const std::size_t byte = std::filesystem::canonical(dir.path()).string().size() + 4;
  EXPECT_NE(r.output.find("its full path, which the records keep, must be UTF-8 text: byte " +
                          std::to_string(byte) + " is not"),
            std::string::npos)
      << r.output;
}

// Each warning of import names its file once: the reader's began with it, and import put it
// in front again ("warning: rec.csv: rec.csv: ...").
TEST(ExitCodes, ImportNamesTheFileOnceInAWarning) {
  TempDir dir;
  const std::string rec = dir.file("rec.csv");
  ASSERT_EQ(standcal_cli(
                "simulate --program paper9 --dwell-s 2 --settle-s 0 --unit-serial SN-1 -o " + rec)
                .exit_code,
            0);
  // A last line cut short: the reader's warning names the file and line.
  std::filesystem::resize_file(rec, std::filesystem::file_size(rec) - 5);
  const CommandOutcome r =
      standcal_cli("import " + rec + " --db sqlite://" + dir.file("lab.sqlite"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // The reader's own warning, "warning: FILE:LINE: last line has no newline ...".
  const std::size_t truncated = r.output.find("last line has no newline");
  ASSERT_NE(truncated, std::string::npos) << r.output;
  const std::size_t line_start = r.output.rfind('\n', truncated) + 1;  // npos + 1 is 0
  EXPECT_EQ(r.output.substr(line_start, 10 + rec.size()), "warning: " + rec + ":") << r.output;
  EXPECT_NE(r.output.find("warning: " + rec + ": the recording states no started_utc"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find(rec + ": " + rec), std::string::npos) << r.output;
}

TEST(ExitCodes, ARuntimeErrorIsOne) {
  const CommandOutcome r = standcal_cli("fit /nonexistent/rec.csv");
  EXPECT_EQ(r.exit_code, code(ExitCode::runtime_error)) << r.output;
  EXPECT_EQ(standcald("--config /nonexistent/standcald.json").exit_code,
            code(ExitCode::runtime_error));
}

// A state directory whose name is not UTF-8 started, and every run.start then failed with
// nlohmann's "type_error.316" (its path goes into run.json and the config hash as JSON text;
// a review, 2026-12-05). It is refused at startup, named.
TEST(ExitCodes, AStateDirectoryNamedInLatin1IsRefusedAtStartup) {
  // Under timeout(1): before the mend the daemon started and ran until killed.
  const CommandOutcome r = run_command("timeout 20 " + std::string(STANDCALD_PATH) +
                                       " --sim --socket /tmp/standcal-exit-code-test.sock "
                                       "--state-dir /tmp/st\xd6te");
  EXPECT_EQ(r.exit_code, code(ExitCode::runtime_error)) << r.output;
  EXPECT_NE(r.output.find("the state directory '/tmp/st\xd6te' must be UTF-8 text: byte 8 is not"),
            std::string::npos)
      << r.output;
}

TEST(ExitCodes, VersionNamesVersionCommitAndBuildType) {
  for (const std::string& program : {std::string(STANDCAL_CLI_PATH), std::string(STANDCALD_PATH)}) {
    const CommandOutcome r = run_command(program + " --version");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.output.find(" (commit "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(" build)"), std::string::npos) << r.output;
  }
}

// A diagnosis: explained is a finding (0), a mismatch nothing explains is 5, too few
// positions to judge is indeterminate (4).
TEST(ExitCodes, DiagnosisVerdicts) {
  TempDir dir;
  const std::string rec = dir.path() + "/paper9.csv";
  ASSERT_EQ(standcal_cli("simulate --program paper9 --seed 3 --dwell-s 5 --settle-s 1 -o " + rec)
                .exit_code,
            0);
  CommandOutcome r = standcal_cli("diagnose " + rec);
  EXPECT_NE(r.output.find("verdict: insufficient_redundancy"), std::string::npos) << r.output;
  EXPECT_EQ(r.exit_code, code(ExitCode::verdict_indeterminate)) << r.output;

  // 600 ug/g2 of scale asymmetry on y: found, and beyond any plausible size, so not
  // explained (DiagnosisBlind.ImplausibleValueIsNotExplained, through the CLI).
  TruthModel truth = default_truth();
  truth.extra_physics.push_back({"scale_asymmetry", "y", 600, 0});
  save_truth(truth, dir.path() + "/model.json");
  std::ofstream(dir.path() + "/diagnostic32.json") << program_to_json(diagnostic32()).dump();
  const std::string asym = dir.path() + "/asym.csv";
  r = standcal_cli("simulate --program " + dir.path() +
                   "/diagnostic32.json --seed 5 --dwell-s 10 --settle-s 2 --model " + dir.path() +
                   "/model.json -o " + asym);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = standcal_cli("diagnose " + asym);
  EXPECT_NE(r.output.find("verdict: unexplained"), std::string::npos) << r.output;
  EXPECT_EQ(r.exit_code, code(ExitCode::unexplained_mismatch)) << r.output;
}

// The README's table is the programs' table, row for row.
TEST(ExitCodes, TheReadmeTableIsTheProgramsTable) {
  std::ifstream in(STANDCAL_README);
  std::stringstream s;
  s << in.rdbuf();
  const std::string readme = s.str();
  int rows = 0;
  for (std::size_t at = readme.find("\n| "); at != std::string::npos;
       at = readme.find("\n| ", at + 1)) {
    const std::size_t end = readme.find('\n', at + 1);
    const std::string line = readme.substr(at + 1, end - at - 1);
    if (line.size() > 4 && line[2] >= '0' && line[2] <= '9' && line[3] == ' ') ++rows;
  }
  EXPECT_EQ(rows, static_cast<int>(kExitCodes.size()))
      << "README rows that start with an exit code";
  for (const ExitCodeMeaning& row : kExitCodes) {
    const std::string expected = "| " + std::to_string(code(row.code)) + " | " + row.meaning + " |";
    EXPECT_NE(readme.find(expected), std::string::npos) << "README lacks the row\n" << expected;
  }
  const CommandOutcome help = standcal_cli("--help-all");
  EXPECT_NE(help.output.find(exit_code_table_text()), std::string::npos) << help.output;
}

}  // namespace
}  // namespace standcal::test
