// Shared code of every Stand backend: range normalisation and the in-position rule.
#include "drivers/stand.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>

namespace standcal::drivers {

namespace {

using Clock = std::chrono::steady_clock;

// Wraps into [-180, 180), exactly: std::remainder is exact for every finite angle, where
// a - 360 * floor(...) loses it all for a huge one (1e308 gave 0 instead of -64).
double wrap_deg(double a_deg) {
  const double r = std::remainder(a_deg, 360.0);  // [-180, 180]
  return r >= 180.0 ? r - 360.0 : r;
}

std::string format_deg(double a_deg) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4f°", a_deg);
  return text;
}

std::string axis_label(const Stand& stand, StandAxis axis) {
  return "stand " + stand.name() + " axis " + std::to_string(static_cast<int>(axis)) + " (" +
         to_string(axis) + ")";
}

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

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
  if (state.stopped_by_heartbeat && state.mode != AxisMode::moving && state.mode != AxisMode::homing)
    return Status::error(ErrorKind::link, where + " was stopped by the controller (heartbeat lost) while " +
                                              doing + ", at " + format_deg(state.angle_deg));
  if (!state.enabled)
    return Status::error(ErrorKind::not_allowed, where + " is disabled while " + doing);
  return Status::ok();
}

}  // namespace

const char* to_string(StandAxis axis) { return axis == StandAxis::outer ? "outer" : "inner"; }

const char* to_string(AxisMode mode) {
  switch (mode) {
    case AxisMode::disabled: return "disabled";
    case AxisMode::idle: return "idle";
    case AxisMode::homing: return "homing";
    case AxisMode::moving: return "moving";
    case AxisMode::in_position: return "in_position";
    case AxisMode::fault: return "fault";
  }
  return "unknown";
}

const char* to_string(Lifecycle lifecycle) {
  switch (lifecycle) {
    case Lifecycle::unconfigured: return "unconfigured";
    case Lifecycle::inactive: return "inactive";
    case Lifecycle::active: return "active";
    case Lifecycle::error: return "error";
  }
  return "unknown";
}

Result<double> normalise_target_deg(const AxisRange& range, double angle_deg, double current_deg) {
  if (!std::isfinite(angle_deg))
    return Status::error(ErrorKind::invalid_argument, "commanded angle is not a number");
  const double wrapped_deg = wrap_deg(angle_deg);  // exact, so every candidate below is too
  if (range.continuous) return wrapped_deg;
  // Tolerance so that a range edge given as 180 still takes a command of -180.
  constexpr double kEdge_deg = 1e-9;
  const double lowest =
      wrapped_deg + 360.0 * std::ceil((range.min_deg - kEdge_deg - wrapped_deg) / 360.0);
  const double reference =
      range.cable_wrap == CableWrap::nearest ? current_deg : 0.5 * (range.min_deg + range.max_deg);
  double best = std::numeric_limits<double>::quiet_NaN();
  for (double candidate = lowest; candidate <= range.max_deg + kEdge_deg; candidate += 360.0) {
    if (std::isnan(best) || std::abs(candidate - reference) < std::abs(best - reference)) best = candidate;
  }
  if (std::isnan(best))
    return Status::error(ErrorKind::limit, "angle " + format_deg(angle_deg) + " is outside the range [" +
                                               format_deg(range.min_deg) + ", " +
                                               format_deg(range.max_deg) + "]");
  return best;
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

Result<double> wait_in_position(Stand& stand, StandAxis axis, double target_deg,
                                const InPositionRule& rule) {
  const AxisRange range = stand.range(axis);
  const auto start = Clock::now();
  std::string doing = "moving to " + format_deg(target_deg);
  bool inside = false;
  Clock::time_point inside_since{};
  for (;;) {
    auto state = stand.read_state(axis);
    if (!state) return state.status();
    const AxisState& s = state.value();
    if (auto stopped = stopped_reason(stand, axis, s, doing); !stopped) return stopped;
    const bool now_inside = std::abs(angle_error_deg(range, s.angle_deg, target_deg)) <= rule.window_deg;
    if (now_inside && !inside) inside_since = Clock::now();
    inside = now_inside;
    if (inside && seconds_since(inside_since) >= rule.dwell_s) return s.angle_deg;
    if (seconds_since(start) > rule.timeout_s) {
      char text[64];
      std::snprintf(text, sizeof text, " within %g s: at ", rule.timeout_s);
      return Status::error(ErrorKind::timeout, axis_label(stand, axis) + " did not reach " +
                                                   format_deg(target_deg) + text +
                                                   format_deg(s.angle_deg) + ", " + to_string(s.mode));
    }
    sleep_s(rule.poll_s);
  }
}

Result<double> wait_homed(Stand& stand, StandAxis axis, double timeout_s, double poll_s) {
  const auto start = Clock::now();
  for (;;) {
    auto state = stand.read_state(axis);
    if (!state) return state.status();
    const AxisState& s = state.value();
    if (auto stopped = stopped_reason(stand, axis, s, "homing"); !stopped) return stopped;
    if (s.homed && s.mode != AxisMode::homing) return s.angle_deg;
    if (seconds_since(start) > timeout_s) {
      char text[64];
      std::snprintf(text, sizeof text, " within %g s: at ", timeout_s);
      return Status::error(ErrorKind::timeout, axis_label(stand, axis) + " did not finish homing" + text +
                                                   format_deg(s.angle_deg) + ", " + to_string(s.mode));
    }
    sleep_s(poll_s);
  }
}

}  // namespace standcal::drivers
