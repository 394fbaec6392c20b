#pragma once
// A static recording of the unit (`standcal fit --unit-static-recording`): one orientation held
// for hours, the default unit with a Gauss-Markov bias wander, as a bench records it for
// `standcal noise`.
#include <cstdint>

#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"

namespace standcal::test {

// `dwell_s` at 10 Hz of a wander of `wander_ug` and `tau_s`, at alpha1 = alpha2 = 0.
inline Recording unit_static_recording(double dwell_s, double wander_ug, double tau_s,
                                       std::uint64_t seed) {
  SimulationRequest req;
  req.program.name = "static";
  req.program.positions = {ProgramPosition{}};
  req.truth = default_truth();
  req.truth.noise.bias_instability_ug = wander_ug;
  req.truth.noise.bias_instability_tau_s = tau_s;
  req.timing.sample_rate_hz = 10;
  req.timing.dwell_s = dwell_s;
  req.seed = seed;
  return simulate_run(req);
}

}  // namespace standcal::test
