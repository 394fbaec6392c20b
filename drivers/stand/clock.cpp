#include "drivers/clock.hpp"

#include <chrono>

namespace standcal::drivers {

namespace {

class SteadyHardwareClock final : public Clock {
 public:
  double now_s() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  double real_seconds(double clock_s) const override { return clock_s; }
};

}  // namespace

std::shared_ptr<const Clock> steady_clock() {
  static const auto clock = std::make_shared<const SteadyHardwareClock>();
  return clock;
}

}  // namespace standcal::drivers
