// `standcal certificate`: the calibration certificate of a finished run (or of an imported
// recording) as one self-contained HTML page (docs/certificate.md).
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
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
#include "tools/standcal/input_options.hpp"

namespace standcal::cli {

namespace {

struct CertificateCliOptions {
  report::CertificateRequest request;
  NoiseCliOptions noise;  // as `standcal fit`'s
  UnitStaticCliOptions unit_static;
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

// WeasyPrint (Debian package weasyprint) lays the page out with its print style sheet: A4,
// the certificate number and "page N of M" in each footer (docs/certificate.md says why this
// renderer). Run as a child process on a private temporary copy; its messages go to a log
// whose last line is the error a user sees.
std::string render_pdf(const std::string& html) {
  std::string dir_template =
      (std::filesystem::temp_directory_path() / "standcal-certificate-XXXXXX").string();
  if (::mkdtemp(dir_template.data()) == nullptr)
    throw std::runtime_error("cannot create a temporary directory for the PDF");
  const std::filesystem::path dir(dir_template);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } cleanup{dir};
  const std::string html_path = (dir / "certificate.html").string();
  const std::string pdf_path = (dir / "certificate.pdf").string();
  const std::string log_path = (dir / "weasyprint.log").string();
  write_file_atomically(html_path, html, "the certificate");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  const char* argv[] = {"weasyprint", html_path.c_str(), pdf_path.c_str(), nullptr};
  pid_t pid = 0;
  const int spawned = ::posix_spawnp(&pid, "weasyprint", &actions, nullptr,
                                     const_cast<char* const*>(argv), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned == ENOENT)
    throw std::runtime_error(
        "PDF output needs WeasyPrint (apt-get install weasyprint); or write the certificate as "
        ".html");
  if (spawned != 0)
    throw std::runtime_error(std::string("cannot start weasyprint: ") + std::strerror(spawned));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::ifstream pdf(pdf_path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(pdf)), std::istreambuf_iterator<char>());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.rfind("%PDF-", 0) != 0) {
    std::ifstream log(log_path);
    std::string line, last;
    while (std::getline(log, line))
      if (!line.empty()) last = line;
    throw std::runtime_error("weasyprint could not render the certificate" +
                             (last.empty() ? "" : ": " + last));
  }
  return bytes;
}

void run_certificate(const CertificateCliOptions& o) {
  // A run id is a name under STATE/runs, never a path ("../../elsewhere/fake").
  if (!o.request.run_id.empty() && !protocol::is_run_id(o.request.run_id))
    throw std::runtime_error(
        "'" + o.request.run_id +
        "' is not a run id (like 20261121T223638Z-AU-0042; `standcal runs` lists "
        "them; certify a recording elsewhere with --recording FILE)");
  report::CertificateRequest request = o.request;
  request.noise = fit_noise_options(o.noise);
  check_unit_static_recording(o.unit_static.path, request.method, o.noise);
  if (o.unit_static.given()) {
    request.unit_static_recording =
        std::make_shared<RawInput>(read_unit_static_recording(o.unit_static));
    print_warnings(request.unit_static_recording->warnings);
  }
  const report::CertificateInput input = report::prepare_certificate(request);
  const std::string html = report::render_certificate_html(input);
  write_certificate(o.output, ends_with(o.output, ".pdf") ? render_pdf(html) : html);
  const std::string verdict = input.conformity ? records::outcome_name(input.conformity->overall)
                                               : std::string("no limits applied");
  if (input.conformity) set_exit_code(conformity_exit_code(input.conformity->overall));
  std::fprintf(stderr, "certificate for %s written to %s (%s); certificate number %s\n",
               input.trace.unit_serial.empty() ? "(no serial)" : input.trace.unit_serial.c_str(),
               o.output.c_str(), verdict.c_str(), input.certificate_number.c_str());
}

void add_certificate_commands(CLI::App& app) {
  auto opts = std::make_shared<CertificateCliOptions>();
  opts->request.state_dir = paths::kStateDir;  // the daemon's default
  CLI::App* cmd =
      app.add_subcommand("certificate", "write the calibration certificate of a run (HTML)");
  cmd->add_option("run_id", opts->request.run_id, "run id (STATE/runs/RUN_ID); or use --recording");
  cmd->add_option("--state-dir", opts->request.state_dir, "the daemon's state directory")
      ->capture_default_str();
  cmd->add_option(
         "--recording", opts->request.recording_path,
         "certify an imported / offline recording (standcal-recording/1 CSV) instead of a run")
      ->check(CLI::ExistingFile);
  cmd->add_option(
         "-o,--output", opts->output,
         "certificate to write (.html, or .pdf rendered by WeasyPrint; - for standard output)")
      ->required();
  cmd->add_option("--limits", opts->request.limits_path,
                  "acceptance limits (standcal-limits/1 JSON)")
      ->check(CLI::ExistingFile);
  cmd->add_option(
         "--budget", opts->request.budget_path,
         "uncertainty budget inputs (standcal-budget/1 JSON): stand tolerances, g, temperature")
      ->check(CLI::ExistingFile);
  cmd->add_option(
         "--lab", opts->request.lab_path,
         "the issuing laboratory (standcal-lab/1 JSON): name, address, accreditation, signatories")
      ->check(CLI::ExistingFile);
  cmd->add_option(
         "--certificate-number", opts->request.certificate_number,
         "the number from the laboratory's register (default PREFIX-YYYYMMDD-HHMMSS-SERIAL)")
      ->check([](const std::string& n) {
        const bool ok = !n.empty() && n.size() <= 64 &&
                        n.find_first_not_of(
                            "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789._/-") ==
                            std::string::npos;
        return ok ? std::string() : std::string("1 to 64 letters, digits, '.', '_', '/' or '-'");
      });
  cmd->add_option("--unit-type", opts->request.unit_type, "which unit type's limits apply");
  cmd->add_option("--method", opts->request.method, "certified estimator: joint (invariant) | full")
      ->check(CLI::IsMember({"joint", "full"}))
      ->capture_default_str();
  add_noise_options(cmd, opts->noise);
  add_unit_static_recording_option(
      cmd, opts->unit_static,
      "the wander its Allan curves pin is taken as the unit's where the "
      "recording's header gives none, and the diagnosis tests "
      "against it; where they show none, they bound the wander the "
      "fits' sigmas allow for, and where they see one they do not pin, they "
      "put a floor under its correlation time for the fits");
  cmd->add_flag(
      "--diagnose", opts->request.diagnose,
      "run the model-mismatch diagnosis now (else RUN_DIR/diagnosis.json is used if present)");
  cmd->callback([opts] { run_certificate(*opts); });
}

const bool certificate_commands_registered = register_command_group(add_certificate_commands);

}  // namespace

}  // namespace standcal::cli
