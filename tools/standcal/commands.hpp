#pragma once
// Sub-commands of `standcal` register themselves here, one file per command group
// (simulate/fit, design, stand, unit, ...), so adding a group never edits main.cpp.
#include <CLI/CLI.hpp>
#include <functional>

#include "protocol/jsonrpc/exit_codes.hpp"

namespace standcal::cli {

// Adds a command group's sub-commands to the application. Called once, at start-up.
using CommandGroup = std::function<void(CLI::App& app)>;

// Registers a group; use from a namespace-scope initialiser, with a name unique to the
// file (scripts/build.sh compiles several files as one in a unity build):
//   static const bool my_commands_registered = register_command_group(add_my_commands);
bool register_command_group(CommandGroup group);

// A command whose finding a script must be able to act on (a FAIL verdict, an unexplained
// mismatch) sets the exit status here; main returns it when the command otherwise succeeded.
void set_exit_code(ExitCode code);

}  // namespace standcal::cli
