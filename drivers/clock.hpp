#pragma once
// The hardware's time: seconds on a monotonic clock that the stand and the unit agree on,
// and how long a span of it lasts in real time. Real hardware runs on the steady clock;
// the simulated backend on one that runs `time_scale` times faster (drivers/sim). The
// daemon reads every stand-side duration (settle, dwell, in-position time-outs, the run
// clock) from the backend's clock, so it never asks whether the hardware is simulated.
#include <memory>

namespace standcal::drivers {

class Clock {
 public:
  virtual ~Clock() = default;
  // Seconds since some fixed point (monotonic).
  virtual double now_s() const = 0;
  // How many real seconds `clock_s` seconds of this clock take.
  virtual double real_seconds(double clock_s) const = 0;
};

// std::chrono::steady_clock, one second per second.
std::shared_ptr<const Clock> steady_clock();

}  // namespace standcal::drivers
