// `standcal certificate`: the calibration certificate of a finished run (or of an imported
// recording) as one self-contained HTML page (docs/certificate.md).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

#include "calib/atomic_file.hpp"
#include "protocol/jsonrpc/paths.hpp"
#include "protocol/jsonrpc/run_id.hpp"
#include "report/certificate/certificate.hpp"
#include "tools/standcal/commands.hpp"

namespace standcal::cli {

namespace {

struct CertificateCliOptions {
  report::CertificateRequest request;
  std::string output;
};

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

void write_in_place(std::ostream& out, const std::string& path, const std::string& html) {
  out << html;
  if (!out.flush()) throw std::runtime_error(path + ": could not write the certificate");
}

// A file is written whole or not at all (written aside, then renamed over the old one);
// "-", a device or a pipe (/dev/stdout, a FIFO) is written in place, since a rename would
// replace the device node rather than write to it.
void write_certificate(const std::string& path, const std::string& html) {
  if (path == "-") return write_in_place(std::cout, "standard output", html);
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (std::filesystem::is_directory(status))
    throw std::runtime_error(path + ": is a directory; name the certificate file (.html)");
  write_file_atomically(path, html, "the certificate");
}

// The ILAC-G8 verdict as a bench script sees it (protocol/jsonrpc/exit_codes.hpp).
ExitCode conformity_exit_code(records::Outcome overall) {
  switch (overall) {
    case records::Outcome::fail:
      return ExitCode::verdict_fail;
    case records::Outcome::indeterminate:
    case records::Outcome::not_evaluated:
      return ExitCode::verdict_indeterminate;
    case records::Outcome::pass:
    case records::Outcome::no_limit:
      break;
  }
  return ExitCode::success;
}

void run_certificate(const CertificateCliOptions& o) {
  // A run id is a name under STATE/runs, never a path ("../../elsewhere/fake").
  if (!o.request.run_id.empty() && !protocol::is_run_id(o.request.run_id))
    throw std::runtime_error(
        "'" + o.request.run_id +
        "' is not a run id (like 20261121T223638Z-AU-0042; `standcal runs` lists "
        "them; certify a recording elsewhere with --recording FILE)");
  if (ends_with(o.output, ".pdf"))
    throw std::runtime_error(o.output + ": PDF is not produced; write .html and print it to PDF from a browser");
  const report::CertificateInput input = report::prepare_certificate(o.request);
  write_certificate(o.output, report::render_certificate_html(input));
  const std::string verdict =
      input.conformity ? records::outcome_name(input.conformity->overall) : std::string("no limits applied");
  if (input.conformity) set_exit_code(conformity_exit_code(input.conformity->overall));
  std::fprintf(stderr, "certificate for %s written to %s (%s)\n",
               input.trace.unit_serial.empty() ? "(no serial)" : input.trace.unit_serial.c_str(), o.output.c_str(),
               verdict.c_str());
}

void add_certificate_commands(CLI::App& app) {
  auto opts = std::make_shared<CertificateCliOptions>();
  opts->request.state_dir = paths::kStateDir;  // the daemon's default
  CLI::App* cmd = app.add_subcommand("certificate", "write the calibration certificate of a run (HTML)");
  cmd->add_option("run_id", opts->request.run_id, "run id (STATE/runs/RUN_ID); or use --recording");
  cmd->add_option("--state-dir", opts->request.state_dir, "the daemon's state directory")
      ->capture_default_str();
  cmd->add_option("--recording", opts->request.recording_path,
                  "certify an imported / offline recording (standcal-recording/1 CSV) instead of a run")
      ->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", opts->output, "certificate to write (.html; - for standard output)")->required();
  cmd->add_option("--limits", opts->request.limits_path, "acceptance limits (standcal-limits/1 JSON)")
      ->check(CLI::ExistingFile);
  cmd->add_option(
         "--budget", opts->request.budget_path,
         "uncertainty budget inputs (standcal-budget/1 JSON): stand tolerances, g, temperature")
      ->check(CLI::ExistingFile);
  cmd->add_option("--unit-type", opts->request.unit_type, "which unit type's limits apply");
  cmd->add_option("--method", opts->request.method, "certified estimator: joint (invariant) | full")
      ->check(CLI::IsMember({"joint", "full"}))
      ->capture_default_str();
  cmd->add_flag("--diagnose", opts->request.diagnose,
                "run the model-mismatch diagnosis now (else RUN_DIR/diagnosis.json is used if present)");
  cmd->callback([opts] { run_certificate(*opts); });
}

const bool certificate_commands_registered = register_command_group(add_certificate_commands);

}  // namespace

}  // namespace standcal::cli
