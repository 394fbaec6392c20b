#pragma once
// Stand: the two-axis test stand as the daemon sees it. Every backend (Modbus
// controller, simulated stand) implements this one interface; the choice is made in
// configuration. The lifecycle follows ros2_control's hardware_interface:
//
//   unconfigured --configure()--> inactive --activate()--> active
//        ^                           |  ^                     |
//        +-------cleanup()-----------+  +----deactivate()-----+
//   any state --(link lost after retries, emergency stop)--> error --recover()--> inactive
//
// inactive: the link is up and every read works; active: motion is allowed too.
// Calls return drivers/status.hpp's Status/Result; nothing about motion is ever assumed
// from a command: ask read_state() (a move is not "done" because it was commanded).
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "calib/axis_range.hpp"
#include "drivers/status.hpp"

namespace standcal::drivers {

// The stand's axes, numbered as in docs/model.md: outer carries α1, inner carries α2.
enum class StandAxis : std::uint8_t { outer = 1, inner = 2 };

enum class Lifecycle : std::uint8_t { unconfigured, inactive, active, error };

// What one axis is doing, as reported by the controller.
enum class AxisMode : std::uint8_t { disabled, idle, homing, moving, in_position, fault };

struct AxisState {
  AxisMode mode = AxisMode::disabled;
  double angle_deg = 0.0;             // actual angle, normalised into the axis range
  bool enabled = false;               // drive powered and holding
  bool homed = false;                 // reference found since power-up
  bool stopped_by_heartbeat = false;  // controller stopped a motion: heartbeat lost
  bool estop = false;                 // emergency stop latched
  int fault_code = 0;                 // 0 = no fault; meaning in fault_text
  std::string fault_text;             // e.g. "following error"
};

// How far an axis may turn (AxisRange, CableWrap) is calib/axis_range.hpp: one type for the
// programmes, the drivers and the daemon's configuration.

// When an axis counts as "in position": inside the window, continuously for the dwell,
// reached before the timeout.
struct InPositionRule {
  double window_deg = 0.001;
  double dwell_s = 0.3;
  double timeout_s = 60.0;
  double poll_s = 0.02;
};

// The lifecycle lives here once (drivers/stand/stand.cpp), as ros2_control's
// hardware_component does it: the public calls decide whether a transition or a command
// is allowed and which state follows; a backend implements only the hardware steps
// (on_configure, on_move_to, ...), each of which does I/O and nothing else. So every
// backend refuses, accepts and fails the same way, and tests/drivers_contract checks it.
//
// The rules, for every backend:
//   configure   unconfigured → inactive, or error when the controller reports a latched
//               e-stop; inactive/active: nothing to do; error: refused, recover first.
//   activate    inactive → active (re-reads the e-stop latch); active: nothing to do.
//   deactivate  active → inactive, stopping both axes; inactive: nothing to do.
//   cleanup     inactive/error → unconfigured; refused while active.
//   recover     error → inactive (re-opens the link, resets the e-stop); refused otherwise.
//   enable, home, move_to: active only (kind `estop` while an e-stop is latched);
//               home needs the axis enabled, move_to enabled and homed.
//   disable, stop: any configured state (taking power or motion away is always allowed).
//   emergency_stop: any state; a configured stand goes to error until recover().
//   read_state: any configured state.
// A backend that loses its link after its retries calls link_lost(): inactive/active →
// error. Transitions are serialised; commands and reads may come from any thread.
class Stand {
 public:
  virtual ~Stand() = default;

  Status configure();   // open the link, read every axis
  Status activate();    // motion commands accepted from now on
  Status deactivate();  // stops both axes, refuses motion
  Status cleanup();     // closes the link
  Status recover();     // re-opens the link, resets an e-stop, re-reads state
  Lifecycle lifecycle() const { return lifecycle_.load(); }

  Status enable(StandAxis axis);   // powers the drive; fails if it did not enable
  Status disable(StandAxis axis);  // removes drive power
  Status home(StandAxis axis);     // starts the reference search; returns once accepted
  Status move_to(StandAxis axis, double angle_deg);  // starts a move; returns once accepted
  Status stop(StandAxis axis);                       // controlled stop, drive stays enabled
  Status emergency_stop();                           // stops and disables both axes at once

  Result<AxisState> read_state(StandAxis axis);       // mode, angle, flags and fault, read now
  Result<double> read_angle_deg(StandAxis axis);      // actual angle, normalised into the range
  virtual AxisRange range(StandAxis axis) const = 0;  // the configured range of the axis
  virtual std::string name() const = 0;  // where the stand is ("tcp://10.0.0.5:502 unit 1")

 protected:
  // The hardware steps. Each is called only when the rules above allow it.
  virtual Status on_configure() = 0;                 // open the link, read both axes
  virtual Result<bool> on_read_estop_latched() = 0;  // the controller's e-stop latch
  virtual Status on_cleanup() = 0;                   // close the link
  virtual Status on_recover() = 0;                   // re-open the link, reset the e-stop
  virtual Status on_enable(StandAxis axis) = 0;      // returns once the drive reports enabled
  virtual Status on_disable(StandAxis axis) = 0;
  virtual Status on_home(StandAxis axis) = 0;
  virtual Status on_move_to(StandAxis axis, double angle_deg) = 0;  // plans the path itself
  virtual Status on_stop(StandAxis axis) = 0;
  virtual Status on_emergency_stop() = 0;
  virtual Result<AxisState> on_read_state(StandAxis axis) = 0;

  // The link is gone after the backend's retries: inactive/active → error.
  void link_lost();

 private:
  enum class ErrorCause : std::uint8_t { none, estop, link };
  Status refuse(const std::string& what) const;  // why `what` is not allowed now
  Status require_configured(const std::string& what) const;
  Status require_active(const std::string& what) const;
  Status require_axis_ready(StandAxis axis, bool need_homed, const std::string& what);
  void enter_error(ErrorCause cause);

  std::atomic<Lifecycle> lifecycle_{Lifecycle::unconfigured};
  std::atomic<ErrorCause> error_cause_{ErrorCause::none};
  std::mutex transition_mutex_;
};

// "outer" / "inner".
const char* to_string(StandAxis axis);
// "disabled", "idle", "homing", "moving", "in_position", "fault".
const char* to_string(AxisMode mode);
// "unconfigured", "inactive", "active", "error".
const char* to_string(Lifecycle lifecycle);
// An angle read or aimed at, as the stand's messages print it: "57.3120°", four decimals
// (0.36″, below any stand's in-position window). A configured value (a range end) is printed
// as given instead (round_trip_text).
std::string format_deg(double angle_deg);

// Maps a commanded angle into the axis range (a ±180° axis takes 270° as −90°), given
// where the axis is now; a limited axis with no equivalent angle inside gives `limit`.
Result<double> normalise_target_deg(const AxisRange& range, double angle_deg, double current_deg);
// The angle to command so the motion respects the range: for a continuous axis the
// current angle plus the shorter signed difference (may leave ±180°; the controller
// counts turns), for a limited axis the normalised target itself.
Result<double> path_target_deg(const AxisRange& range, double angle_deg, double current_deg);
// Folds a raw controller angle into the range's frame ([-180, 180) for a continuous axis).
double normalise_reading_deg(const AxisRange& range, double raw_deg);
// Signed angular difference a − b, wrapped into [-180, 180) for a continuous axis.
double angle_error_deg(const AxisRange& range, double a_deg, double b_deg);

// How a wait passes time. The stand's clock (seconds, monotonic: the simulated clock for a
// simulated stand running faster than real time) and a pause that may do other work while
// it waits — the daemon serves its requests and e-stops there.
struct WaitClock {
  std::function<double()> now_s;
  std::function<void(double seconds)> pause_s;
};
// The steady clock and a sleep, for the CLI and the tests.
WaitClock steady_wait_clock();

// One axis and the angle it was sent to, normalised into its range.
struct AxisTarget {
  StandAxis axis;
  double target_deg;
};

// The one in-position rule (the CLI and the daemon both wait with it). Every poll reads
// every axis; the wait fails at once on a read error, a fault, a latched e-stop, a heartbeat
// stop (the controller halted the axis: it is not moving or homing and has the flag set) or
// a disabled drive. The axes are in position once each is inside `rule.window_deg` of its
// target and neither moving nor homing, continuously for `rule.dwell_s`. Only axes seen
// outside that past `rule.timeout_s` have failed: a poll that comes late (a loaded PC, a
// fast simulated clock) and finds them in position starts their dwell. Returns the angles
// read at the end, in the order of `targets`.
Result<std::vector<double>> wait_in_position(Stand& stand, std::span<const AxisTarget> targets,
                                             const InPositionRule& rule,
                                             const WaitClock& clock = steady_wait_clock());
// The same for one axis.
Result<double> wait_in_position(Stand& stand, StandAxis axis, double target_deg,
                                const InPositionRule& rule,
                                const WaitClock& clock = steady_wait_clock());
// Waits until every axis of `axes` reports homed and not homing, within `timeout_s`, with the
// same stop conditions; returns their angles in order.
Result<std::vector<double>> wait_homed(Stand& stand, std::span<const StandAxis> axes,
                                       double timeout_s, double poll_s,
                                       const WaitClock& clock = steady_wait_clock());
// The same for one axis.
Result<double> wait_homed(Stand& stand, StandAxis axis, double timeout_s, double poll_s = 0.02,
                          const WaitClock& clock = steady_wait_clock());

}  // namespace standcal::drivers
