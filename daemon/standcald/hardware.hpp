#pragma once
// The stand and the unit the configuration chose (docs/architecture.md: real and
// simulated hardware share one interface; the choice is made here, never in the
// sequencer).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "calib/model.hpp"
#include "daemon/standcald/config.hpp"
#include "drivers/accel_unit.hpp"
#include "drivers/clock.hpp"
#include "drivers/stand.hpp"

namespace standcal::daemon {

struct Hardware {
  std::shared_ptr<drivers::Stand> stand;
  std::shared_ptr<drivers::AccelUnit> unit;
  // The stand's clock: settle and dwell times, in-position time-outs and the run clock are
  // read on it (the simulated backend's runs faster than real time).
  std::shared_ptr<const drivers::Clock> clock = drivers::steady_clock();
  // What the backend does once the unit is mounted as `mount` (the run's first mount, and
  // each re-mount the operator confirms): the simulated unit takes the new attitude; on
  // real hardware a person has re-mounted it and there is nothing to do.
  std::function<void(Mount)> remount = [](Mount) {};
  std::string description;  // "sim (time x100)", "modbus tcp://... + socketcan can0"
  // What the configuration allows but an operator should hear of (a stand timing whose
  // retries outlast its watchdog), each naming the file and key; the daemon logs them.
  std::vector<std::string> warnings;
};

// Builds the configured backends; throws ConfigError naming the key when a backend is
// not available in this build or cannot be created.
Hardware make_hardware(const DaemonConfig& config);

}  // namespace standcal::daemon
