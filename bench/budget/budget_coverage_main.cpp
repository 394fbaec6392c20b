// standcal-bench-budget-coverage: the GUM budget's 95 % coverage by Monte Carlo, for the
// invariant and the full-vector estimators (docs/calibration.md "Uncertainty budget").
//   build/release/bench/budget/standcal-bench-budget-coverage [--runs N] [--seed S]
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>

#include "bench/budget/budget_coverage.hpp"

using namespace standcal;

int main(int argc, char** argv) {
  CLI::App app{"Monte Carlo coverage of the uncertainty budget's expanded U"};
  int runs = 1000;
  std::uint64_t seed = 1;
  app.add_option("--runs", runs, "runs per estimator")->check(CLI::Range(10, 100000));
  app.add_option("--seed", seed, "first seed");
  int threads = 2;
  app.add_option("--threads", threads, "worker threads")->check(CLI::Range(1, 64));
  CLI11_PARSE(app, argc, argv);

  Program program{"paper9-twice", {}};
  for (int round = 0; round < 2; ++round)
    for (const ProgramPosition& p : paper9().positions) program.positions.push_back(p);
  std::printf("programme %s (%zu positions), %d runs per estimator, seeds %llu..., %d threads\n",
              program.name.c_str(), program.positions.size(), runs,
              static_cast<unsigned long long>(seed), threads);
  const BudgetConfig config = budget_mc::data_sheet_config();
  std::printf(
      "drawn: angle zero +-%.0f\", orthogonality +-%.0f\", level +-%.0f\", mounting +-%.0f\" "
      "(uniform); "
      "u(g) %.0e m/s^2 (normal); tempco +-%.1f ug/degC, +-%.1f ppm/degC (uniform); 22->25 degC; "
      "white 3 ug per dwell mean\n",
      config.angle_zero_arcsec, config.orthogonality_arcsec, config.level_arcsec,
      config.mounting_arcsec, config.g_standard_uncertainty_mps2,
      config.unit_types.at("QA-2000").bias_ug_per_c,
      config.unit_types.at("QA-2000").scale_ppm_per_c);
  for (const char* estimator : {"joint", "full"}) {
    budget_mc::Setup setup;
    setup.estimator = estimator;
    setup.program = program;
    setup.runs = runs;
    setup.first_seed = seed;
    setup.config = config;
    setup.threads = threads;
    const auto start = std::chrono::steady_clock::now();
    const budget_mc::Coverage c = budget_mc::run_coverage(setup);
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("\n%s estimator: %d runs (%d failed), %.1f s\n", estimator, c.runs, c.failed, s);
    std::printf("  %-8s %9s %9s %9s %7s\n", "param", "covered", "z2(u_c)", "B share", "k");
    for (std::size_t j = 0; j < kUnitParameterCount; ++j) {
      std::printf("  %-8s %8.1f%% %9.2f %8.0f%% %7.3f%s\n",
                  std::string(kUnitParameterNames[j]).c_str(), 100 * c.covered[j], c.z2[j],
                  100 * c.type_b_share[j], c.mean_k[j],
                  std::abs(c.covered[j] - 0.95) <= 0.02 ? "" : "   <- outside 95 +- 2 %");
    }
  }
  return 0;
}
