#include "drivers/sim/sim_backend.hpp"

#include "drivers/sim/sim_stand.hpp"
#include "drivers/sim/sim_unit.hpp"

namespace standcal::drivers {

SimBackend make_sim_backend(const SimBackendConfig& config) {
  auto clock = std::make_shared<const SimClock>(config.time_scale);
  auto stand = std::make_shared<SimStand>(
      clock, SimStandConfig{config.outer, config.inner, config.move_rate_deg_s});
  auto unit =
      std::make_shared<SimUnit>(clock, stand, config.truth, config.seed, config.sample_rate_hz);
  SimBackend backend;
  backend.stand = stand;
  backend.unit = unit;
  backend.clock = clock;
  backend.remount = [unit](Mount m) { unit->remount(m); };
  backend.set_unit_silent = [unit](bool silent) { unit->set_silent(silent); };
  return backend;
}

}  // namespace standcal::drivers
