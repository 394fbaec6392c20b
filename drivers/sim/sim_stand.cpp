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

Status SimStand::require_active(const char* what) const {
  if (estop_) return Status::error(ErrorKind::estop, std::string("sim stand: emergency stop is latched; cannot ") + what);
  if (lifecycle_ != Lifecycle::active)
    return Status::error(ErrorKind::not_allowed,
                         std::string("sim stand is ") + to_string(lifecycle_) + ", not active; cannot " + what);
  return Status::ok();
}

Status SimStand::configure() {
  std::lock_guard lock(mutex_);
  if (estop_) return Status::error(ErrorKind::estop, "sim stand: emergency stop is latched; reset it first");
  if (lifecycle_ == Lifecycle::unconfigured) lifecycle_ = Lifecycle::inactive;
  return Status::ok();
}

Status SimStand::activate() {
  std::lock_guard lock(mutex_);
  if (lifecycle_ != Lifecycle::inactive && lifecycle_ != Lifecycle::active)
    return Status::error(ErrorKind::not_allowed, std::string("sim stand is ") + to_string(lifecycle_) +
                                                     "; configure it before activating");
  lifecycle_ = Lifecycle::active;
  return Status::ok();
}

Status SimStand::deactivate() {
  std::lock_guard lock(mutex_);
  const double t = clock_->now_s();
  for (Axis& a : axes_) freeze(a, t);
  if (lifecycle_ == Lifecycle::active) lifecycle_ = Lifecycle::inactive;
  return Status::ok();
}

Status SimStand::cleanup() {
  std::lock_guard lock(mutex_);
  if (lifecycle_ == Lifecycle::active)
    return Status::error(ErrorKind::not_allowed, "sim stand is active; deactivate it first");
  lifecycle_ = Lifecycle::unconfigured;
  return Status::ok();
}

Status SimStand::recover() {
  std::lock_guard lock(mutex_);
  estop_ = false;
  lifecycle_ = Lifecycle::inactive;
  return Status::ok();
}

Lifecycle SimStand::lifecycle() const {
  std::lock_guard lock(mutex_);
  return lifecycle_;
}

Status SimStand::enable(StandAxis axis) {
  std::lock_guard lock(mutex_);
  if (Status s = require_active("enable an axis"); !s) return s;
  axis_of(axis).enabled = true;
  return Status::ok();
}

Status SimStand::disable(StandAxis axis) {
  std::lock_guard lock(mutex_);
  if (Status s = require_active("disable an axis"); !s) return s;
  Axis& a = axis_of(axis);
  freeze(a, clock_->now_s());
  a.enabled = false;
  return Status::ok();
}

Status SimStand::home(StandAxis axis) {
  std::lock_guard lock(mutex_);
  if (Status s = require_active("home"); !s) return s;
  Axis& a = axis_of(axis);
  if (!a.enabled) return Status::error(ErrorKind::not_allowed, std::string("sim stand axis ") + to_string(axis) + " is disabled; enable it first");
  const double t = clock_->now_s();
  freeze(a, t);
  a.target_deg = 0;
  a.start_t_s = t;
  a.commanded = a.homing = true;
  return Status::ok();
}

Status SimStand::move_to(StandAxis axis, double angle_deg) {
  std::lock_guard lock(mutex_);
  if (Status s = require_active("move"); !s) return s;
  Axis& a = axis_of(axis);
  if (!a.enabled) return Status::error(ErrorKind::not_allowed, std::string("sim stand axis ") + to_string(axis) + " is disabled; enable it first");
  const double t = clock_->now_s();
  settle_homing(a, t);
  if (!a.homed) return Status::error(ErrorKind::not_allowed, std::string("sim stand axis ") + to_string(axis) + " is not homed; home it first");
  const double now_deg = angle_at(a, t);
  const Result<double> target = path_target_deg(a.range, angle_deg, now_deg);
  if (!target) return target.status();
  freeze(a, t);
  a.target_deg = target.value();
  a.start_t_s = t;
  a.commanded = true;
  return Status::ok();
}

Status SimStand::stop(StandAxis axis) {
  std::lock_guard lock(mutex_);
  freeze(axis_of(axis), clock_->now_s());
  return Status::ok();
}

Status SimStand::emergency_stop() {
  std::lock_guard lock(mutex_);
  const double t = clock_->now_s();
  for (Axis& a : axes_) {
    freeze(a, t);
    a.enabled = false;
  }
  estop_ = true;
  lifecycle_ = Lifecycle::error;
  return Status::ok();
}

Result<AxisState> SimStand::read_state(StandAxis axis) {
  std::lock_guard lock(mutex_);
  if (lifecycle_ == Lifecycle::unconfigured)
    return Status::error(ErrorKind::not_allowed, "sim stand is unconfigured; nothing to read");
  Axis& a = axis_of(axis);
  const double t = clock_->now_s();
  settle_homing(a, t);
  AxisState s;
  s.angle_deg = normalise_reading_deg(a.range, angle_at(a, t));
  s.enabled = a.enabled;
  s.homed = a.homed;
  s.estop = estop_;
  if (!a.enabled) s.mode = AxisMode::disabled;
  else if (a.homing) s.mode = AxisMode::homing;
  else if (a.commanded && !arrived(a, t)) s.mode = AxisMode::moving;
  else if (a.commanded) s.mode = AxisMode::in_position;
  else s.mode = AxisMode::idle;
  return s;
}

Result<double> SimStand::read_angle_deg(StandAxis axis) {
  Result<AxisState> s = read_state(axis);
  if (!s) return s.status();
  return s.value().angle_deg;
}

AxisRange SimStand::range(StandAxis axis) const { return axis_of(axis).range; }

std::array<double, 2> SimStand::angles_at_deg(double t_s) const {
  std::lock_guard lock(mutex_);
  return {angle_at(axes_[0], t_s), angle_at(axes_[1], t_s)};
}

}  // namespace standcal::drivers
