#pragma once
// Simulated time shared by the simulated stand and unit: real time times a scale, so a
// one-hour run can take 36 s at time_scale 100 while both devices agree on "now".
#include <chrono>

#include "drivers/clock.hpp"

namespace standcal::drivers {

class SimClock final : public Clock {
 public:
  explicit SimClock(double time_scale);
  double now_s() const override;  // simulated seconds since construction
  double real_seconds(double simulated_s) const override { return simulated_s / time_scale_; }
  void sleep_s(double simulated_s) const;  // sleeps simulated_s / time_scale real seconds
  double time_scale() const { return time_scale_; }

 private:
  std::chrono::steady_clock::time_point start_;
  double time_scale_;
};

}  // namespace standcal::drivers
