#pragma once
// One simulated stand axis: a trapezoidal profile (rate and acceleration limits) that a
// second-order drive follows (small overshoot and settling), an encoder with
// quantization and noise, homing, soft limits, and the faults the emulator injects.
#include <cstdint>
#include <optional>
#include <random>

#include "drivers/modbus/register_map.hpp"

namespace standcal::emu {

using drivers::modbus::AxisCommand;
using drivers::modbus::StateCode;

struct AxisModel {
  double max_speed_dps = 30.0;
  double accel_dps2 = 90.0;
  double home_speed_dps = 15.0;
  std::optional<double> soft_min_deg;  // soft limits of the commanded angle, if any
  std::optional<double> soft_max_deg;
  double following_limit_deg = 5.0;  // |profile − actual| beyond this faults the axis
  double natural_freq_radps = 60.0;  // the drive's closed loop
  double damping = 0.6;
  double settle_window_deg =
      0.0002;  // "in position" once the profile ended and actual is this close
  double encoder_lsb_deg = 0.0001;
  double encoder_noise_deg = 0.00003;
  double unhomed_offset_deg = 0.5;  // reading error before homing: the counter started anywhere
};

// Why a command cannot be executed now; maps to a Modbus exception.
enum class Refusal { none, cannot_now, bad_value };

class AxisSim {
 public:
  AxisSim(AxisModel model, double start_deg, unsigned seed);

  Refusal check(AxisCommand command, double target_deg) const;  // before accepting a write
  void command(AxisCommand command, double target_deg, double speed_dps);
  void step(double dt_s);          // advances simulated time
  bool stop_for_heartbeat_loss();  // controlled stop, stays enabled, flagged; false: was not moving
  void emergency_stop();           // immediate stop, disabled, latched
  void reset();                    // clears the e-stop latch (axis stays disabled)
  void inject_drive_fault();       // trips the drive (fault code 3)

  void set_stuck(bool stuck) { stuck_ = stuck; }
  void set_slow(double factor) { slow_ = factor < 1.0 ? 1.0 : factor; }
  // A mis-tuned drive: from the next move on it settles `deg` past the target.
  void set_overshoot(double deg) { overshoot_deg_ = deg; }

  StateCode state() const;
  std::uint16_t flags() const;
  std::uint16_t fault_code() const { return static_cast<std::uint16_t>(fault_); }
  std::uint16_t command_count() const { return command_count_; }
  double reading_deg();  // quantized, noisy encoder reading
  double true_deg() const { return x_; }

 private:
  enum class Motion { none, move, home, stop };
  void trip(int code);
  void profile_step(double h);
  void drive_step(double h);
  void finish_if_settled();
  double to_true(double reading_deg) const { return reading_deg + reference_deg_; }

  AxisModel model_;
  std::mt19937 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
  double x_ = 0.0, xd_ = 0.0;  // actual angle and rate (true frame)
  double p_ = 0.0, pv_ = 0.0;  // profile angle and rate (true frame)
  double goal_ = 0.0, speed_dps_ = 0.0;
  double reference_deg_ = 0.0;  // reading = true − reference
  Motion motion_ = Motion::none;
  bool enabled_ = false, homed_ = false, at_target_ = false;
  bool estop_ = false, stopped_by_heartbeat_ = false, stuck_ = false;
  double slow_ = 1.0;
  double overshoot_deg_ = 0.0;  // the fault's size
  double offset_deg_ = 0.0;     // signed offset the drive adds to the profile in this move
  int fault_ = 0;
  std::uint16_t command_count_ = 0;
};

}  // namespace standcal::emu
