#pragma once
// AccelUnit: the accelerometer unit as the daemon sees it, whatever carries its data
// (SocketCAN now, a simulated unit in drivers/sim). Real and simulated backends are
// chosen in configuration, never with `if (simulated)` (docs/architecture.md).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/status.hpp"

namespace standcal::drivers {

// One joined sample of the three accelerometers.
struct AccelSample {
  double t_s = 0;                      // sample time (CLOCK_REALTIME seconds)
  std::array<double, 3> force_mps2{};  // specific force along x, y, z in m/s^2
  double temperature_c = 0;            // unit temperature, NaN when not reported
  std::uint64_t counter = 0;           // sample counter, unwrapped across wraps
};

// CAN controller error state (ISO 11898 fault confinement).
enum class BusState { error_active, error_passive, bus_off };

// Human-readable bus state: "error-active", "error-passive", "bus-off".
const char* bus_state_name(BusState s);

// Counters that tell an operator whether the link to the unit is healthy.
struct AccelUnitHealth {
  std::uint64_t frames = 0;              // data frames received
  std::uint64_t samples = 0;             // complete samples delivered
  std::uint64_t incomplete_samples = 0;  // samples dropped: a frame missing or late
  std::uint64_t duplicate_frames = 0;    // frames seen twice (ignored)
  std::uint64_t late_frames = 0;         // frames for samples already delivered/dropped
  std::uint64_t unknown_frames = 0;      // frames with ids or lengths the layout lacks
  std::uint64_t counter_resyncs = 0;     // sample counter jumped (unit restarted?)
  std::uint64_t error_frames = 0;        // CAN error frames received
  std::uint64_t restarts = 0;            // controller restarts after bus-off
  BusState bus_state = BusState::error_active;
  bool silent = false;  // sampling found no frame within the silence timeout (until the next frame)
};

class AccelUnit {
 public:
  virtual ~AccelUnit() = default;
  // Where the unit is, for messages ("can0", "fd 5", "sim").
  virtual std::string name() const = 0;
  // Begins accepting samples; earlier queued data is discarded.
  virtual Status start() = 0;
  // Stops accepting samples.
  virtual Status stop() = 0;
  // Collects the samples of the next `seconds` from the call on (what queued before it is not
  // returned: the stand may have been moving); fails if the unit falls silent.
  virtual Result<std::vector<AccelSample>> collect(double seconds) = 0;
  // The next `seconds` of the previous collect's series since start(), from where its window
  // ended: what the unit sent while the caller was busy in between comes first (at once if
  // that already fills the window), so a dwell collected in chunks is one unbroken series,
  // which its Allan curves and noise model take it to be, spanning the sum of its chunks'
  // lengths. With no collect since start(), as collect.
  virtual Result<std::vector<AccelSample>> collect_more(double seconds) = 0;
  // Link health counters since construction.
  virtual AccelUnitHealth health() const = 0;
};

inline const char* bus_state_name(BusState s) {
  switch (s) {
    case BusState::error_active:
      return "error-active";
    case BusState::error_passive:
      return "error-passive";
    case BusState::bus_off:
      return "bus-off";
  }
  return "unknown";
}

}  // namespace standcal::drivers
