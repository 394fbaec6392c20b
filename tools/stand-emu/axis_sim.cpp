// Simulated axis motion (see axis_sim.hpp).
#include "tools/stand-emu/axis_sim.hpp"

#include <algorithm>
#include <cmath>

namespace standcal::emu {

using drivers::modbus::kFaultDrive;
using drivers::modbus::kFaultFollowing;
using drivers::modbus::kFlagEnabled;
using drivers::modbus::kFlagEstop;
using drivers::modbus::kFlagHomed;
using drivers::modbus::kFlagStoppedByHeartbeat;

AxisSim::AxisSim(AxisModel model, double start_deg, unsigned seed)
    : model_(model),
      rng_(seed),
      x_(start_deg),
      p_(start_deg),
      goal_(start_deg),
      reference_deg_(-model.unhomed_offset_deg) {}

Refusal AxisSim::check(AxisCommand command, double target_deg) const {
  const bool motion = command == AxisCommand::move || command == AxisCommand::home;
  if (estop_ && command != AxisCommand::none && command != AxisCommand::stop &&
      command != AxisCommand::disable)
    return Refusal::cannot_now;
  if (motion && (!enabled_ || fault_ != 0)) return Refusal::cannot_now;
  if (command == AxisCommand::move && ((model_.soft_min_deg && target_deg < *model_.soft_min_deg) ||
                                       (model_.soft_max_deg && target_deg > *model_.soft_max_deg)))
    return Refusal::bad_value;
  return Refusal::none;
}

void AxisSim::command(AxisCommand command, double target_deg, double speed_dps) {
  ++command_count_;
  switch (command) {
    case AxisCommand::none:
      break;
    case AxisCommand::enable:
      if (estop_) break;
      fault_ = 0;
      enabled_ = true;
      p_ = x_, pv_ = 0.0;
      offset_deg_ = 0.0;  // hold where it is
      break;
    case AxisCommand::disable:
      enabled_ = false;
      motion_ = Motion::none;
      at_target_ = false;
      break;
    case AxisCommand::home:
      motion_ = Motion::home;
      goal_ = 0.0;  // the reference mark sits at true zero
      offset_deg_ = 0.0;
      speed_dps_ = model_.home_speed_dps;
      at_target_ = false;
      stopped_by_heartbeat_ = false;
      break;
    case AxisCommand::move:
      motion_ = Motion::move;
      goal_ = to_true(target_deg);
      offset_deg_ = goal_ == x_ ? 0.0 : std::copysign(overshoot_deg_, goal_ - x_);
      speed_dps_ = speed_dps > 0 ? std::min(speed_dps, model_.max_speed_dps) : model_.max_speed_dps;
      at_target_ = false;
      stopped_by_heartbeat_ = false;
      break;
    case AxisCommand::stop:
      if (motion_ == Motion::none) break;
      motion_ = Motion::stop;
      // Decelerate at the acceleration limit from where the profile is.
      goal_ = p_ + pv_ * std::abs(pv_) / (2.0 * model_.accel_dps2 / slow_);
      at_target_ = false;
      break;
  }
}

bool AxisSim::stop_for_heartbeat_loss() {
  if (motion_ != Motion::move && motion_ != Motion::home) return false;
  command(AxisCommand::stop, 0.0, 0.0);
  stopped_by_heartbeat_ = true;
  return true;
}

void AxisSim::emergency_stop() {
  enabled_ = false;
  estop_ = true;
  motion_ = Motion::none;
  at_target_ = false;
  p_ = x_, pv_ = 0.0, xd_ = 0.0;
}

void AxisSim::reset() { estop_ = false; }

void AxisSim::inject_drive_fault() { trip(kFaultDrive); }

void AxisSim::trip(int code) {
  fault_ = code;
  enabled_ = false;
  motion_ = Motion::none;
  at_target_ = false;
  p_ = x_, pv_ = 0.0;
}

void AxisSim::profile_step(double h) {
  if (motion_ == Motion::none) return;
  const double accel = model_.accel_dps2 / slow_;
  const double vmax = (motion_ == Motion::stop ? model_.max_speed_dps : speed_dps_) / slow_;
  const double d = goal_ - p_;
  if (std::abs(d) < 1e-9 && std::abs(pv_) <= accel * h) {
    p_ = goal_, pv_ = 0.0;
    return;
  }
  // Fastest rate that can still stop at the goal, limited by the speed.
  const double v_wanted = std::copysign(std::min(vmax, std::sqrt(2.0 * accel * std::abs(d))), d);
  pv_ += std::clamp(v_wanted - pv_, -accel * h, accel * h);
  const double before = goal_ - p_;
  p_ += pv_ * h;
  if ((goal_ - p_) * before < 0.0) p_ = goal_, pv_ = 0.0;  // never pass the goal
}

void AxisSim::drive_step(double h) {
  if (!enabled_ || stuck_) {
    xd_ = 0.0;
    if (!enabled_) p_ = x_, pv_ = 0.0;
    return;
  }
  const double w = model_.natural_freq_radps;
  const double xdd = w * w * (p_ + offset_deg_ - x_) - 2.0 * model_.damping * w * xd_;
  xd_ += xdd * h;
  x_ += xd_ * h;
}

void AxisSim::finish_if_settled() {
  if (motion_ == Motion::none || p_ != goal_ || pv_ != 0.0) return;
  // The controller judges "settled" against its own (offset) set-point: an overshooting
  // drive still reports in position.
  if (std::abs(x_ - offset_deg_ - goal_) > model_.settle_window_deg || std::abs(xd_) > 0.01) return;
  if (motion_ == Motion::home) {
    homed_ = true;
    reference_deg_ = 0.0;
  }
  at_target_ = motion_ == Motion::move;
  motion_ = Motion::none;
}

void AxisSim::step(double dt_s) {
  constexpr double kSubstep_s = 0.0005;
  while (dt_s > 0.0) {
    const double h = std::min(dt_s, kSubstep_s);
    dt_s -= h;
    if (enabled_) profile_step(h);
    drive_step(h);
    if (enabled_ && std::abs(p_ - x_) > model_.following_limit_deg) trip(kFaultFollowing);
  }
  finish_if_settled();
}

StateCode AxisSim::state() const {
  if (fault_ != 0) return StateCode::fault;
  if (!enabled_) return StateCode::disabled;
  if (motion_ == Motion::home) return StateCode::homing;
  if (motion_ != Motion::none) return StateCode::moving;
  return at_target_ ? StateCode::in_position : StateCode::idle;
}

std::uint16_t AxisSim::flags() const {
  std::uint16_t f = 0;
  if (enabled_) f |= kFlagEnabled;
  if (homed_) f |= kFlagHomed;
  if (stopped_by_heartbeat_) f |= kFlagStoppedByHeartbeat;
  if (estop_) f |= kFlagEstop;
  return f;
}

double AxisSim::reading_deg() {
  const double noisy = x_ - reference_deg_ + model_.encoder_noise_deg * noise_(rng_);
  return std::round(noisy / model_.encoder_lsb_deg) * model_.encoder_lsb_deg;
}

}  // namespace standcal::emu
