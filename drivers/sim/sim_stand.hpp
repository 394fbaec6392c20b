#pragma once
// A simulated two-axis stand: constant-rate moves, homing to 0 and the emergency-stop
// latch of a real controller (the lifecycle is drivers/stand's). Angles are what its angle sensors
// read; the stand errors of calib's model act in the simulated unit (sim_unit.hpp).
#include <array>
#include <memory>
#include <mutex>

#include "drivers/sim/sim_clock.hpp"
#include "drivers/stand.hpp"

namespace standcal::drivers {

struct SimStandConfig {
  AxisRange outer;  // alpha1
  AxisRange inner;  // alpha2
  double move_rate_deg_s = 10;
};

class SimStand : public Stand {
 public:
  SimStand(std::shared_ptr<const SimClock> clock, const SimStandConfig& config);

  AxisRange range(StandAxis axis) const override;
  std::string name() const override { return "sim"; }

  // Both angles (alpha1, alpha2) at simulated time t_s, for the simulated unit.
  std::array<double, 2> angles_at_deg(double t_s) const;

 protected:
  // The simulated controller's steps; drivers/stand/lifecycle.cpp decides when they run.
  Status on_configure() override { return Status::ok(); }
  Result<bool> on_read_estop_latched() override;
  Status on_cleanup() override { return Status::ok(); }
  Status on_recover() override;
  Status on_enable(StandAxis axis) override;
  Status on_disable(StandAxis axis) override;
  Status on_home(StandAxis axis) override;
  Status on_move_to(StandAxis axis, double angle_deg) override;
  Status on_stop(StandAxis axis) override;
  Status on_emergency_stop() override;
  Result<AxisState> on_read_state(StandAxis axis) override;

 private:
  struct Axis {
    AxisRange range;
    bool enabled = false;
    bool homed = false;
    bool homing = false;
    bool commanded = false;  // a move or homing was commanded and not stopped
    double start_deg = 0;
    double target_deg = 0;
    double start_t_s = 0;
  };
  Axis& axis_of(StandAxis axis) { return axes_[axis == StandAxis::outer ? 0 : 1]; }
  const Axis& axis_of(StandAxis axis) const { return axes_[axis == StandAxis::outer ? 0 : 1]; }
  double angle_at(const Axis& a, double t_s) const;
  bool arrived(const Axis& a, double t_s) const;
  void settle_homing(Axis& a, double t_s);
  void freeze(Axis& a, double t_s);

  std::shared_ptr<const SimClock> clock_;
  double rate_deg_s_;
  mutable std::mutex mutex_;
  bool estop_ = false;  // the controller's latch: survives cleanup and configure
  std::array<Axis, 2> axes_;
};

}  // namespace standcal::drivers
