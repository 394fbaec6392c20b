#pragma once
// Simulated time shared by the simulated stand and unit: real time times a scale, so a
// one-hour run can take 36 s at time_scale 100 while both devices agree on "now".
#include <chrono>

namespace standcal::drivers {

class SimClock {
 public:
  explicit SimClock(double time_scale);
  double now_s() const;                    // simulated seconds since construction
  void sleep_s(double simulated_s) const;  // sleeps simulated_s / time_scale real seconds
  double time_scale() const { return time_scale_; }

 private:
  std::chrono::steady_clock::time_point start_;
  double time_scale_;
};

}  // namespace standcal::drivers
