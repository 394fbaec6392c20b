#pragma once
// What the blind diagnosis tests share: a recording simulated with a concealed truth, and
// a printout of what the diagnosis said (shown with the test's output when it fails).
#include <cstdint>
#include <cstdio>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/programs.hpp"
#include "calib/simulator.hpp"

namespace standcal::blind {

inline Recording simulate(const Program& program, const TruthModel& truth, std::uint64_t seed,
                          double dwell_s = 10) {
  SimulationRequest req;
  req.program = program;
  req.truth = truth;
  req.seed = seed;
  req.timing.dwell_s = dwell_s;
  req.timing.settle_s = 2;
  return simulate_run(req);
}

inline void print(const Diagnosis& d) {
  std::printf("verdict %s, baseline chi2/dof %.2f, final %.2f\n", d.verdict.c_str(),
              d.baseline.chi2_dof, d.final_chi2_dof);
  for (const auto& s : d.summary) std::printf("  %s\n", s.c_str());
  for (std::size_t i = 0; i < d.candidates.size() && i < 5; ++i)
    std::printf("  cand %s %s dchi2 %.1f bic %.1f press %.1f val %.2f +- %.2f\n",
                d.candidates[i].effect.c_str(), d.candidates[i].axis.c_str(),
                d.candidates[i].delta_chi2, d.candidates[i].delta_bic, d.candidates[i].press_gain,
                d.candidates[i].value, d.candidates[i].sigma);
}

}  // namespace standcal::blind
