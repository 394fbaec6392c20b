// Shared code of every Stand backend: range normalisation and the in-position rule (the
// lifecycle is in lifecycle.cpp).
#include "drivers/stand.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>

#include "calib/text.hpp"

namespace standcal::drivers {

namespace {

using SteadyClock = std::chrono::steady_clock;

std::string axis_label(const Stand& stand, StandAxis axis) {
  return "stand " + stand.name() + " axis " + std::to_string(static_cast<int>(axis)) + " (" +
         to_string(axis) + ")";
}

double seconds_since(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

bool in_motion(const AxisState& s) {
  return s.mode == AxisMode::moving || s.mode == AxisMode::homing;
}

bool in_window(const AxisRange& range, const AxisState& s, double target_deg, double window_deg) {
  return std::abs(angle_error_deg(range, s.angle_deg, target_deg)) <= window_deg;
}

// A state that ends any wait at once, or ok.
Status stopped_reason(const Stand& stand, StandAxis axis, const AxisState& state,
                      const std::string& doing) {
  const std::string where = axis_label(stand, axis);
  if (state.mode == AxisMode::fault)
    return Status::error(ErrorKind::fault, where + " faulted while " + doing + ": code " +
                                               std::to_string(state.fault_code) + " (" +
                                               state.fault_text + ") at " +
                                               format_deg(state.angle_deg));
  if (state.estop)
    return Status::error(ErrorKind::estop, where + " is in emergency stop while " + doing);
  // The flag stays set until the next command; an axis moving again has had one.
  if (state.stopped_by_heartbeat && !in_motion(state))
    return Status::error(ErrorKind::link,
                         where + " was stopped by the controller (heartbeat lost) while " + doing +
                             ", at " + format_deg(state.angle_deg));
  if (!state.enabled)
    return Status::error(ErrorKind::not_allowed, where + " is disabled while " + doing);
  return Status::ok();
}

// The time-out message: the first axis outside its window, where it is and what it does.
Status not_in_position(const Stand& stand, std::span<const AxisTarget> targets,
                       const std::vector<AxisState>& states, const InPositionRule& rule) {
  char within[64];
  std::snprintf(within, sizeof within, " within %g s: at ", rule.timeout_s);
  std::size_t worst = 0;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    if (!in_window(stand.range(targets[i].axis), states[i], targets[i].target_deg,
                   rule.window_deg)) {
      worst = i;
      break;
    }
    if (in_motion(states[i])) worst = i;  // inside the window but still moving
  }
  const AxisTarget& t = targets[worst];
  const AxisState& s = states[worst];
  return Status::error(ErrorKind::timeout, axis_label(stand, t.axis) + " did not reach " +
                                               format_deg(t.target_deg) + within +
                                               format_deg(s.angle_deg) + ", " + to_string(s.mode));
}

}  // namespace

const char* to_string(StandAxis axis) { return axis == StandAxis::outer ? "outer" : "inner"; }

const char* to_string(AxisMode mode) {
  switch (mode) {
    case AxisMode::disabled:
      return "disabled";
    case AxisMode::idle:
      return "idle";
    case AxisMode::homing:
      return "homing";
    case AxisMode::moving:
      return "moving";
    case AxisMode::in_position:
      return "in_position";
    case AxisMode::fault:
      return "fault";
  }
  return "unknown";
}

const char* to_string(Lifecycle lifecycle) {
  switch (lifecycle) {
    case Lifecycle::unconfigured:
      return "unconfigured";
    case Lifecycle::inactive:
      return "inactive";
    case Lifecycle::active:
      return "active";
    case Lifecycle::error:
      return "error";
  }
  return "unknown";
}

std::string format_deg(double angle_deg) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4f°", angle_deg);
  return text;
}

Result<double> normalise_target_deg(const AxisRange& range, double angle_deg, double current_deg) {
  if (!std::isfinite(angle_deg))
    return Status::error(ErrorKind::invalid_argument, "commanded angle is not a number");
  const double reference_deg =
      range.cable_wrap == CableWrap::nearest ? current_deg : range.middle_deg();
  if (const auto target_deg = equivalent_angle_deg(range, angle_deg, reference_deg))
    return *target_deg;
  // The angle as commanded and the ends as configured: one just past an end reads as past
  // it (90.00001°, not 90.0000°, outside [-90°, 90°]), and an end of 90.00004° is not
  // printed as 90.0000°.
  return Status::error(ErrorKind::limit, "angle " + round_trip_text(angle_deg) +
                                             "° is outside the range [" +
                                             round_trip_text(range.min_deg) + "°, " +
                                             round_trip_text(range.max_deg) + "°]");
}

Result<double> path_target_deg(const AxisRange& range, double angle_deg, double current_deg) {
  auto target = normalise_target_deg(range, angle_deg, current_deg);
  if (!target || !range.continuous) return target;
  return current_deg + wrap_deg(target.value() - current_deg);
}

double normalise_reading_deg(const AxisRange& range, double raw_deg) {
  return range.continuous ? wrap_deg(raw_deg) : raw_deg;
}

double angle_error_deg(const AxisRange& range, double a_deg, double b_deg) {
  return range.continuous ? wrap_deg(a_deg - b_deg) : a_deg - b_deg;
}

WaitClock steady_wait_clock() {
  const auto start = SteadyClock::now();
  return {[start] { return seconds_since(start); },
          [](double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }};
}

Result<std::vector<double>> wait_in_position(Stand& stand, std::span<const AxisTarget> targets,
                                             const InPositionRule& rule, const WaitClock& clock) {
  const double start_s = clock.now_s();
  double inside_since_s = -1;  // < 0: not inside
  std::vector<AxisState> states(targets.size());
  for (;;) {
    bool inside = true;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const AxisTarget& t = targets[i];
      auto state = stand.read_state(t.axis);
      if (!state) return state.status();
      states[i] = state.value();
      if (auto stopped =
              stopped_reason(stand, t.axis, states[i], "moving to " + format_deg(t.target_deg));
          !stopped)
        return stopped;
      inside = inside && in_window(stand.range(t.axis), states[i], t.target_deg, rule.window_deg) &&
               !in_motion(states[i]);
    }
    const double now_s = clock.now_s();
    if (!inside) {
      inside_since_s = -1;
    } else if (inside_since_s < 0) {
      inside_since_s = now_s;
    }
    if (inside && now_s - inside_since_s >= rule.dwell_s) {
      std::vector<double> angles_deg;
      for (const AxisState& s : states) angles_deg.push_back(s.angle_deg);
      return angles_deg;
    }
    if (!inside && now_s - start_s > rule.timeout_s)
      return not_in_position(stand, targets, states, rule);
    clock.pause_s(rule.poll_s);
  }
}

Result<double> wait_in_position(Stand& stand, StandAxis axis, double target_deg,
                                const InPositionRule& rule, const WaitClock& clock) {
  const AxisTarget target{axis, target_deg};
  auto reached = wait_in_position(stand, std::span<const AxisTarget>(&target, 1), rule, clock);
  if (!reached) return reached.status();
  return reached.value().front();
}

Result<std::vector<double>> wait_homed(Stand& stand, std::span<const StandAxis> axes,
                                       double timeout_s, double poll_s, const WaitClock& clock) {
  const double start_s = clock.now_s();
  for (;;) {
    std::vector<double> angles_deg;
    bool done = true;
    for (StandAxis axis : axes) {
      auto state = stand.read_state(axis);
      if (!state) return state.status();
      const AxisState& s = state.value();
      if (auto stopped = stopped_reason(stand, axis, s, "homing"); !stopped) return stopped;
      const bool axis_done = s.homed && s.mode != AxisMode::homing;
      done = done && axis_done;
      angles_deg.push_back(s.angle_deg);
      if (!axis_done && clock.now_s() - start_s > timeout_s) {
        char text[64];
        std::snprintf(text, sizeof text, " within %g s: at ", timeout_s);
        return Status::error(ErrorKind::timeout,
                             axis_label(stand, axis) + " did not finish homing" + text +
                                 format_deg(s.angle_deg) + ", " + to_string(s.mode));
      }
    }
    if (done) return angles_deg;
    clock.pause_s(poll_s);
  }
}

Result<double> wait_homed(Stand& stand, StandAxis axis, double timeout_s, double poll_s,
                          const WaitClock& clock) {
  auto homed = wait_homed(stand, std::span<const StandAxis>(&axis, 1), timeout_s, poll_s, clock);
  if (!homed) return homed.status();
  return homed.value().front();
}

}  // namespace standcal::drivers
