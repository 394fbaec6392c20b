#include "drivers/sim/sim_stand.hpp"

#include <cmath>

namespace standcal::drivers {

SimStand::SimStand(std::shared_ptr<const SimClock> clock, const SimStandConfig& config)
    : clock_(std::move(clock)), rate_deg_s_(config.move_rate_deg_s) {
  axes_[0].range = config.outer;
  axes_[1].range = config.inner;
}

double SimStand::angle_at(const Axis& a, double t_s) const {
  if (!a.commanded) return a.start_deg;
  const double travel = a.target_deg - a.start_deg;
  const double done = std::min(std::abs(travel), rate_deg_s_ * std::max(0.0, t_s - a.start_t_s));
  return a.start_deg + std::copysign(done, travel);
}

bool SimStand::arrived(const Axis& a, double t_s) const {
  return std::abs(a.target_deg - a.start_deg) <= rate_deg_s_ * (t_s - a.start_t_s);
}

void SimStand::freeze(Axis& a, double t_s) {
  a.start_deg = angle_at(a, t_s);
  a.target_deg = a.start_deg;
  a.commanded = false;
  a.homing = false;
}

void SimStand::settle_homing(Axis& a, double t_s) {
  if (a.homing && arrived(a, t_s)) {
    a.homing = false;
    a.homed = true;
  }
}

Result<bool> SimStand::on_read_estop_latched() {
  std::lock_guard lock(mutex_);
  return estop_;
}

Status SimStand::on_recover() {
  std::lock_guard lock(mutex_);
  estop_ = false;
  return Status::ok();
}

Status SimStand::on_enable(StandAxis axis) {
  std::lock_guard lock(mutex_);
  axis_of(axis).enabled = true;
  return Status::ok();
}

Status SimStand::on_disable(StandAxis axis) {
  std::lock_guard lock(mutex_);
  Axis& a = axis_of(axis);
  freeze(a, clock_->now_s());
  a.enabled = false;
  return Status::ok();
}

Status SimStand::on_home(StandAxis axis) {
  std::lock_guard lock(mutex_);
  Axis& a = axis_of(axis);
  const double t = clock_->now_s();
  freeze(a, t);
  a.target_deg = 0;
  a.start_t_s = t;
  a.commanded = a.homing = true;
  return Status::ok();
}

Status SimStand::on_move_to(StandAxis axis, double angle_deg) {
  std::lock_guard lock(mutex_);
  Axis& a = axis_of(axis);
  const double t = clock_->now_s();
  settle_homing(a, t);
  const double now_deg = angle_at(a, t);
  const Result<double> target = path_target_deg(a.range, angle_deg, now_deg);
  if (!target) return target.status();
  freeze(a, t);
  a.target_deg = target.value();
  a.start_t_s = t;
  a.commanded = true;
  return Status::ok();
}

Status SimStand::on_stop(StandAxis axis) {
  std::lock_guard lock(mutex_);
  freeze(axis_of(axis), clock_->now_s());
  return Status::ok();
}

Status SimStand::on_emergency_stop() {
  std::lock_guard lock(mutex_);
  const double t = clock_->now_s();
  for (Axis& a : axes_) {
    freeze(a, t);
    a.enabled = false;
  }
  estop_ = true;
  return Status::ok();
}

Result<AxisState> SimStand::on_read_state(StandAxis axis) {
  std::lock_guard lock(mutex_);
  Axis& a = axis_of(axis);
  const double t = clock_->now_s();
  settle_homing(a, t);
  AxisState s;
  s.angle_deg = normalise_reading_deg(a.range, angle_at(a, t));
  s.enabled = a.enabled;
  s.homed = a.homed;
  s.estop = estop_;
  if (!a.enabled)
    s.mode = AxisMode::disabled;
  else if (a.homing)
    s.mode = AxisMode::homing;
  else if (a.commanded && !arrived(a, t))
    s.mode = AxisMode::moving;
  else if (a.commanded)
    s.mode = AxisMode::in_position;
  else
    s.mode = AxisMode::idle;
  return s;
}

AxisRange SimStand::range(StandAxis axis) const { return axis_of(axis).range; }

std::array<double, 2> SimStand::angles_at_deg(double t_s) const {
  std::lock_guard lock(mutex_);
  return {angle_at(axes_[0], t_s), angle_at(axes_[1], t_s)};
}

}  // namespace standcal::drivers
