#pragma once
// A static recording of the unit (`standcal fit --unit-static-recording`): one orientation held
// for hours, the default unit with a Gauss-Markov bias wander, as a bench records it for
// `standcal noise`.
#include <cstdint>

#include <string>

#include "calib/allan.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording.hpp"
#include "calib/simulator.hpp"

namespace standcal::test {

// `dwell_s` at 10 Hz of a wander of `wander_ug` and `tau_s`, at alpha1 = alpha2 = 0; under the
// default unit's white noise, or `density_ug_rthz`.
inline Recording unit_static_recording(double dwell_s, double wander_ug, double tau_s,
                                       std::uint64_t seed, double density_ug_rthz = 0) {
  SimulationRequest req;
  req.program.name = "static";
  req.program.positions = {ProgramPosition{}};
  req.truth = default_truth();
  if (density_ug_rthz > 0) req.truth.noise.density_ug_rthz = density_ug_rthz;
  req.truth.noise.bias_instability_ug = wander_ug;
  req.truth.noise.bias_instability_tau_s = tau_s;
  req.timing.sample_rate_hz = 10;
  req.timing.dwell_s = dwell_s;
  req.seed = seed;
  return simulate_run(req);
}

// Two hours of a unit whose wander (30 ug, 1200 s) its curves see and do not pin: they put a
// floor under its correlation time (unit_static_recording(7200, 30, 1200, this seed)).
inline constexpr std::uint64_t kSlowWanderStaticSeed = 6;

// The Allan curves of two still hours of the default unit (seed 4), as standcald's runs carry
// them in their header (kHeaderUnitStaticCurves) where its static recording shows no wander.
inline std::string still_unit_curves_text() {
  const UnitStaticAllan still = stand_unit_static_allan(
      raw_input_of(unit_static_recording(7200, 0, 300, 4)), kStandardGravity_mps2);
  return wander_curves_text(still.allan.wander_curves.value());
}

}  // namespace standcal::test
