#pragma once
// The simulated hardware as one configured backend: a SimStand and a SimUnit on one
// simulated clock. The daemon picks it in configuration like any real backend.
#include <cstdint>
#include <functional>
#include <memory>

#include "calib/simulator.hpp"
#include "drivers/accel_unit.hpp"
#include "drivers/clock.hpp"
#include "drivers/stand.hpp"

namespace standcal::drivers {

struct SimBackendConfig {
  TruthModel truth = default_truth();
  double sample_rate_hz = 100;
  double time_scale = 1;  // simulated seconds per real second
  std::uint64_t seed = 1;
  AxisRange outer;  // limited ±180° unless configured
  AxisRange inner;
  double move_rate_deg_s = 10;
};

struct SimBackend {
  std::shared_ptr<Stand> stand;
  std::shared_ptr<AccelUnit> unit;
  std::shared_ptr<const Clock> clock;  // the one both run on
  // The simulated operator re-mounting the unit (classic24's re-mount steps). Empty on
  // real hardware, where a person does it.
  std::function<void(Mount)> remount;
  // Fault injection for tests: make the unit silent (true) or talk again (false).
  std::function<void(bool)> set_unit_silent;
};

SimBackend make_sim_backend(const SimBackendConfig& config);

}  // namespace standcal::drivers
