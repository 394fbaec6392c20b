// The Stand lifecycle, once for every backend: which transition and which command is
// allowed in which state, and which state follows (the rules are listed in stand.hpp).
// Backends only do the hardware steps.
#include <string>

#include "drivers/stand.hpp"

namespace standcal::drivers {

namespace {

std::string axis_text(StandAxis axis) { return std::string(to_string(axis)) + " axis"; }

}  // namespace

void Stand::enter_error(ErrorCause cause) {
  error_cause_ = cause;
  lifecycle_ = Lifecycle::error;
}

void Stand::link_lost() {
  Lifecycle from = lifecycle_.load();
  while (from == Lifecycle::inactive || from == Lifecycle::active) {
    if (lifecycle_.compare_exchange_weak(from, Lifecycle::error)) {
      error_cause_ = ErrorCause::link;
      return;
    }
  }
}

Status Stand::refuse(const std::string& what) const {
  const Lifecycle now = lifecycle_.load();
  const std::string where = "stand " + name() + " is " + to_string(now);
  if (now == Lifecycle::error && error_cause_.load() == ErrorCause::estop)
    return Status::error(ErrorKind::estop, where + ", its emergency stop latched: recover first (" +
                                               what + " refused)");
  if (now == Lifecycle::error)
    return Status::error(ErrorKind::not_allowed,
                         where + ", its link lost: recover first (" + what + " refused)");
  return Status::error(ErrorKind::not_allowed, where + ": " + what + " is not allowed");
}

Status Stand::require_configured(const std::string& what) const {
  if (lifecycle_.load() == Lifecycle::unconfigured)
    return Status::error(
        ErrorKind::not_allowed,
        "stand " + name() + " is unconfigured: configure first (" + what + " refused)");
  return Status::ok();
}

Status Stand::require_active(const std::string& what) const {
  const Lifecycle now = lifecycle_.load();
  if (now == Lifecycle::active) return Status::ok();
  if (now == Lifecycle::inactive)
    return Status::error(ErrorKind::not_allowed,
                         "stand " + name() + " is inactive: activate first (" + what + " refused)");
  if (now == Lifecycle::unconfigured) return require_configured(what);
  return refuse(what);
}

// Reads, never assumes: the axis must report itself enabled (and homed) now.
Status Stand::require_axis_ready(StandAxis axis, bool need_homed, const std::string& what) {
  const Result<AxisState> state = read_state(axis);
  if (!state) return state.status();
  const std::string where = "stand " + name() + " " + axis_text(axis);
  if (state.value().estop)
    return Status::error(ErrorKind::estop,
                         where + " is in emergency stop: recover first (" + what + " refused)");
  if (!state.value().enabled)
    return Status::error(ErrorKind::not_allowed, where + " is disabled: enable it before " + what);
  if (need_homed && !state.value().homed)
    return Status::error(ErrorKind::not_allowed, where + " is not homed: home it before " + what);
  return Status::ok();
}

Status Stand::configure() {
  std::lock_guard lock(transition_mutex_);
  const Lifecycle now = lifecycle_.load();
  if (now == Lifecycle::inactive || now == Lifecycle::active) return Status::ok();
  if (now == Lifecycle::error) return refuse("configuring");
  if (Status opened = on_configure(); !opened) return opened;
  // A latched e-stop is an error to recover from, found now rather than at the first move.
  const Result<bool> latched = on_read_estop_latched();
  if (!latched) {
    // Still unconfigured: the link on_configure opened (and its heartbeat) is closed again,
    // so nothing talks to a controller the stand does not count as configured.
    (void)on_cleanup();
    return latched.status();
  }
  if (latched.value()) {
    enter_error(ErrorCause::estop);
  } else {
    error_cause_ = ErrorCause::none;
    lifecycle_ = Lifecycle::inactive;
  }
  return Status::ok();
}

Status Stand::activate() {
  std::lock_guard lock(transition_mutex_);
  const Lifecycle now = lifecycle_.load();
  if (now == Lifecycle::active) return Status::ok();
  if (now != Lifecycle::inactive)
    return now == Lifecycle::unconfigured ? require_configured("activating") : refuse("activating");
  const Result<bool> latched = on_read_estop_latched();
  if (!latched) return latched.status();
  if (latched.value()) {
    enter_error(ErrorCause::estop);
    return refuse("activating");
  }
  lifecycle_ = Lifecycle::active;
  return Status::ok();
}

Status Stand::deactivate() {
  std::lock_guard lock(transition_mutex_);
  const Lifecycle now = lifecycle_.load();
  if (now == Lifecycle::inactive) return Status::ok();
  if (now != Lifecycle::active)
    return now == Lifecycle::unconfigured ? require_configured("deactivating")
                                          : refuse("deactivating");
  const Status outer = on_stop(StandAxis::outer);
  const Status inner = on_stop(StandAxis::inner);
  Lifecycle expected = Lifecycle::active;  // a lost link during the stops leaves it in error
  lifecycle_.compare_exchange_strong(expected, Lifecycle::inactive);
  return !outer ? outer : inner;
}

Status Stand::cleanup() {
  std::lock_guard lock(transition_mutex_);
  const Lifecycle now = lifecycle_.load();
  if (now == Lifecycle::unconfigured) return Status::ok();
  if (now == Lifecycle::active)
    return Status::error(ErrorKind::not_allowed,
                         "stand " + name() + " is active: deactivate() before cleanup()");
  (void)on_cleanup();  // closing cannot fail in a way that keeps the link usable
  error_cause_ = ErrorCause::none;
  lifecycle_ = Lifecycle::unconfigured;
  return Status::ok();
}

Status Stand::recover() {
  std::lock_guard lock(transition_mutex_);
  const Lifecycle now = lifecycle_.load();
  if (now != Lifecycle::error)
    return Status::error(ErrorKind::not_allowed, "stand " + name() + " is " + to_string(now) +
                                                     ", not in error: nothing to recover");
  if (Status recovered = on_recover(); !recovered) return recovered;
  error_cause_ = ErrorCause::none;
  lifecycle_ = Lifecycle::inactive;
  return Status::ok();
}

Status Stand::enable(StandAxis axis) {
  const std::string what = "enabling the " + axis_text(axis);
  if (Status allowed = require_active(what); !allowed) return allowed;
  return on_enable(axis);
}

Status Stand::disable(StandAxis axis) {
  if (Status allowed = require_configured("disabling the " + axis_text(axis)); !allowed)
    return allowed;
  return on_disable(axis);
}

Status Stand::home(StandAxis axis) {
  const std::string what = "homing the " + axis_text(axis);
  if (Status allowed = require_active(what); !allowed) return allowed;
  if (Status ready = require_axis_ready(axis, false, what); !ready) return ready;
  return on_home(axis);
}

Status Stand::move_to(StandAxis axis, double angle_deg) {
  const std::string what = "moving the " + axis_text(axis);
  if (Status allowed = require_active(what); !allowed) return allowed;
  if (Status ready = require_axis_ready(axis, true, what); !ready) return ready;
  return on_move_to(axis, angle_deg);
}

Status Stand::stop(StandAxis axis) {
  if (Status allowed = require_configured("stopping the " + axis_text(axis)); !allowed)
    return allowed;
  return on_stop(axis);
}

// Never waits for a transition in progress: a stand being configured may need stopping.
Status Stand::emergency_stop() {
  const Status stopped = on_emergency_stop();
  // Even when the command was not answered: the stand cannot be trusted to move until
  // recover() has re-read it. An unconfigured stand finds the latch at configure().
  if (lifecycle_.load() != Lifecycle::unconfigured) enter_error(ErrorCause::estop);
  return stopped;
}

Result<AxisState> Stand::read_state(StandAxis axis) {
  if (Status allowed = require_configured("reading the " + axis_text(axis)); !allowed)
    return allowed;
  return on_read_state(axis);
}

Result<double> Stand::read_angle_deg(StandAxis axis) {
  const Result<AxisState> state = read_state(axis);
  if (!state) return state.status();
  return state.value().angle_deg;
}

}  // namespace standcal::drivers
