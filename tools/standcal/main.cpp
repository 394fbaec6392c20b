// standcal: offline calibration analysis and (later) the operator client of standcald.
#include <cstdio>
#include <exception>
#include <vector>

#include "standcal/version.hpp"
#include "tools/standcal/commands.hpp"

namespace standcal::cli {

static std::vector<CommandGroup>& command_groups() {
  static std::vector<CommandGroup> groups;
  return groups;
}

bool register_command_group(CommandGroup group) {
  command_groups().push_back(std::move(group));
  return true;
}

}  // namespace standcal::cli

int main(int argc, char** argv) {
  CLI::App app{"standcal: accelerometer-unit calibration on a two-axis stand"};
  app.set_version_flag("--version", standcal::kVersion);
  app.require_subcommand(1);
  for (const auto& group : standcal::cli::command_groups()) group(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "standcal: %s\n", e.what());
    return 1;
  }
  return 0;
}
