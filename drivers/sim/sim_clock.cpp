#include "drivers/sim/sim_clock.hpp"

#include <thread>

namespace standcal::drivers {

SimClock::SimClock(double time_scale)
    : start_(std::chrono::steady_clock::now()), time_scale_(time_scale > 0 ? time_scale : 1.0) {}

double SimClock::now_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() *
         time_scale_;
}

void SimClock::sleep_s(double simulated_s) const {
  if (simulated_s <= 0) return;
  std::this_thread::sleep_for(std::chrono::duration<double>(simulated_s / time_scale_));
}

}  // namespace standcal::drivers
