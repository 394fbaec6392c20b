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
#include <cstdint>
#include <string>

#include "drivers/status.hpp"

namespace standcal::drivers {

// The stand's axes, numbered as in docs/model.md: outer carries α1, inner carries α2.
enum class StandAxis : std::uint8_t { outer = 1, inner = 2 };

enum class Lifecycle : std::uint8_t { unconfigured, inactive, active, error };

// What one axis is doing, as reported by the controller.
enum class AxisMode : std::uint8_t { disabled, idle, homing, moving, in_position, fault };

struct AxisState {
  AxisMode mode = AxisMode::disabled;
  double angle_deg = 0.0;            // actual angle, normalised into the axis range
  bool enabled = false;              // drive powered and holding
  bool homed = false;                // reference found since power-up
  bool stopped_by_heartbeat = false; // controller stopped a motion: heartbeat lost
  bool estop = false;                // emergency stop latched
  int fault_code = 0;                // 0 = no fault; meaning in fault_text
  std::string fault_text;            // e.g. "following error"
};

// How far an axis may turn. A continuous axis (slip ring) turns freely and always takes
// the shorter way; a limited axis (cables) stays inside [min_deg, max_deg].
enum class CableWrap : std::uint8_t {
  nearest,  // of the equivalent angles inside the range, go to the one nearest the axis
  centred,  // of the equivalent angles inside the range, go to the one nearest its centre
};

struct AxisRange {
  bool continuous = true;
  double min_deg = -180.0;  // only for a limited axis
  double max_deg = 180.0;   // only for a limited axis
  CableWrap cable_wrap = CableWrap::nearest;
};

// When an axis counts as "in position": inside the window, continuously for the dwell,
// reached before the timeout.
struct InPositionRule {
  double window_deg = 0.001;
  double dwell_s = 0.3;
  double timeout_s = 60.0;
  double poll_s = 0.02;
};

class Stand {
 public:
  virtual ~Stand() = default;

  virtual Status configure() = 0;                 // unconfigured → inactive (error if an e-stop is latched): open the link, read every axis
  virtual Status activate() = 0;                  // inactive → active: motion commands accepted from now on
  virtual Status deactivate() = 0;                // active → inactive: stops both axes, refuses motion
  virtual Status cleanup() = 0;                   // inactive/error → unconfigured: closes the link
  virtual Status recover() = 0;                   // error → inactive: re-opens the link, resets an e-stop, re-reads state
  virtual Lifecycle lifecycle() const = 0;        // where the lifecycle stands now

  virtual Status enable(StandAxis axis) = 0;      // powers the drive (active only); fails if it did not enable
  virtual Status disable(StandAxis axis) = 0;     // removes drive power (active only)
  virtual Status home(StandAxis axis) = 0;        // starts the reference search; returns once accepted
  virtual Status move_to(StandAxis axis, double angle_deg) = 0;  // starts a move to the normalised angle; returns once accepted
  virtual Status stop(StandAxis axis) = 0;        // controlled stop, drive stays enabled
  virtual Status emergency_stop() = 0;            // stops and disables both axes at once; lifecycle → error

  virtual Result<AxisState> read_state(StandAxis axis) = 0;  // mode, angle, flags and fault, read now
  virtual Result<double> read_angle_deg(StandAxis axis) = 0; // actual angle, normalised into the range
  virtual AxisRange range(StandAxis axis) const = 0;         // the configured range of the axis
  virtual std::string name() const = 0;           // where the stand is, for messages ("tcp://10.0.0.5:502 unit 1")
};

// "outer" / "inner".
const char* to_string(StandAxis axis);
// "disabled", "idle", "homing", "moving", "in_position", "fault".
const char* to_string(AxisMode mode);
// "unconfigured", "inactive", "active", "error".
const char* to_string(Lifecycle lifecycle);

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

// Waits until `axis` is in position at `target_deg` by `rule`; returns the angle read at
// the end. Fails at once on a fault, an e-stop or a heartbeat stop; on timeout says where
// the axis is and what it is doing.
Result<double> wait_in_position(Stand& stand, StandAxis axis, double target_deg,
                                const InPositionRule& rule);
// Waits until `axis` reports homed and not homing, within `timeout_s`; returns its angle.
Result<double> wait_homed(Stand& stand, StandAxis axis, double timeout_s, double poll_s = 0.02);

}  // namespace standcal::drivers
