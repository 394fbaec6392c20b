// standcal: offline calibration analysis and (later) the operator client of standcald.
#include <cstdio>
#include <exception>
#include <vector>

#include "standcal/version.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/daemon_connection.hpp"

namespace standcal::cli {

static std::vector<CommandGroup>& command_groups() {
  static std::vector<CommandGroup> groups;
  return groups;
}

bool register_command_group(CommandGroup group) {
  command_groups().push_back(std::move(group));
  return true;
}

static ExitCode& command_exit_code() {
  static ExitCode code = ExitCode::success;
  return code;
}

void set_exit_code(ExitCode code) { command_exit_code() = code; }

}  // namespace standcal::cli

int main(int argc, char** argv) {
  CLI::App app{"standcal: accelerometer-unit calibration on a two-axis stand"};
  app.set_version_flag("--version", standcal::kVersionLine);
  // --help-all: every command's options in one text, which the man page is made from.
  app.set_help_all_flag("--help-all", "Print the help of every command and exit");
  app.footer(standcal::exit_code_table_text());
  app.require_subcommand(1);
  standcal::cli::add_global_daemon_options(app);
  for (const auto& group : standcal::cli::command_groups()) group(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return standcal::parse_error_exit_status(app.exit(e));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "standcal: %s\n", e.what());
    return standcal::exit_status(standcal::ExitCode::runtime_error);
  }
  return standcal::exit_status(standcal::cli::command_exit_code());
}
