#pragma once
// The stand and the unit the configuration chose (docs/architecture.md: real and
// simulated hardware share one interface; the choice is made here, never in the
// sequencer).
#include <functional>
#include <memory>
#include <string>

#include "calib/model.hpp"
#include "daemon/standcald/config.hpp"
#include "drivers/accel_unit.hpp"
#include "drivers/stand.hpp"

namespace standcal::daemon {

struct Hardware {
  std::shared_ptr<drivers::Stand> stand;
  std::shared_ptr<drivers::AccelUnit> unit;
  // Re-mounts the unit when the operator confirms a re-mount step; set only where no
  // person does it (the simulated backend).
  std::function<void(Mount)> simulated_remount;
  double time_scale = 1;    // simulated seconds per real second (1 on real hardware)
  std::string description;  // "sim (time x100)", "modbus tcp://... + socketcan can0"
};

// Builds the configured backends; throws ConfigError naming the key when a backend is
// not available in this build or cannot be created.
Hardware make_hardware(const DaemonConfig& config);

}  // namespace standcal::daemon
