// standcal-bench-faults: runs each fault of issue 7 (tests/faults/fault_cases.hpp) for a
// number of seeded tries on the real standcald, standcal-stand-emu and standcal-can-emu,
// and prints the table: fault, tries, survived, positions lost. A try survives when the
// stand ended stopped, the run's state was truthful, no recorded position was lost or
// changed, and resume completed the run. Failures are printed with the broken promise.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "tests/faults/fault_cases.hpp"
#include "tools/cli_checks.hpp"

using namespace standcal::faults;

int main(int argc, char** argv) {
  CLI::App app{"standcal-bench-faults: fault injection on the real daemon, table of survivals"};
  int tries = 3, kill_tries = 20;
  unsigned seed = 1;
  std::vector<std::string> only;
  app.add_option("--tries", tries, "tries per fault (seeds seed..seed+tries-1)")
      ->check(standcal::cli_checks::kPositive);
  app.add_option("--kill-tries", kill_tries,
                 "tries of sigkill and power_loss (each a seeded point)")
      ->check(standcal::cli_checks::kPositive);
  app.add_option("--seed", seed, "first seed");
  app.add_option("--only", only, "run only these faults (names as in the table)");
  CLI11_PARSE(app, argc, argv);

  RigOptions o;
  o.daemon_path = STANDCALD_PATH;
  o.stand_emu_path = STANDCAL_STAND_EMU_PATH;
  o.can_emu_path = STANDCAL_CAN_EMU_PATH;
  const bool have_socat = std::filesystem::exists("/usr/bin/socat");

  std::printf("%-22s %6s %9s %16s  %s\n", "fault", "tries", "survived", "positions lost",
              "state after the fault");
  int all_tries = 0, all_survived = 0, all_lost = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (const FaultCase& c : all_cases()) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    if (c.rtu && !have_socat) {
      std::printf("%-22s %6s %9s %16s  (socat not installed)\n", c.name.c_str(), "-", "-", "-");
      continue;
    }
    const int n = c.inject_after_positions < 0 ? kill_tries : tries;
    int survived = 0, lost = 0;
    std::map<std::string, int> states;
    for (int i = 0; i < n; ++i) {
      const Trial t = run_trial(o, c, seed + static_cast<unsigned>(i));
      survived += t.survived ? 1 : 0;
      lost += t.positions_lost;
      ++states[t.state_after_fault.empty() ? "?" : t.state_after_fault];
      if (!t.survived)
        std::fprintf(stderr, "  %s seed %u: %s\n", c.name.c_str(), seed + i, t.failure.c_str());
    }
    std::string state_text;
    for (const auto& [state, count] : states)
      state_text += (state_text.empty() ? "" : ", ") + state + " " + std::to_string(count);
    std::printf("%-22s %6d %9d %16d  %s\n", c.name.c_str(), n, survived, lost, state_text.c_str());
    std::fflush(stdout);
    all_tries += n;
    all_survived += survived;
    all_lost += lost;
  }
  const double took_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%-22s %6d %9d %16d  (%.0f s)\n", "all", all_tries, all_survived, all_lost, took_s);
  return all_survived == all_tries && all_lost == 0 ? 0 : 1;
}
