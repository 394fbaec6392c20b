#pragma once
// The stand controller's Modbus register map (docs/stand-modbus.md), shared by the driver
// and the emulator so both speak exactly the documented map. Every address and the
// scaling come from the config file, so a lab can match its controller without
// recompiling; the defaults are the documented map.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drivers/stand.hpp"
#include "drivers/status.hpp"

namespace standcal::drivers::modbus {

// Which 16-bit word of a 32-bit value comes first in the register space.
enum class WordOrder : std::uint8_t { high_first, low_first };

// Per-axis registers. Holding (read/write): target (2 words), speed, command.
// Input (read-only): state, flags, angle (2 words), fault code, command count.
struct AxisRegisters {
  std::uint16_t target = 0;
  std::uint16_t speed = 2;
  std::uint16_t command = 3;
  std::uint16_t state = 0;
  std::uint16_t flags = 1;
  std::uint16_t angle = 2;
  std::uint16_t fault = 4;
  std::uint16_t command_count = 5;
};

struct RegisterMap {
  // Holding registers.
  std::uint16_t heartbeat = 0;             // counter the driver changes every period
  std::uint16_t heartbeat_timeout_ms = 1;  // 0 disables the controller's watchdog
  std::uint16_t global_command = 2;        // GlobalCommand
  // Input registers.
  std::uint16_t global_flags = 0;  // GlobalFlag bits
  std::uint16_t map_version = 1;   // kMapVersion
  std::array<AxisRegisters, 2> axes{AxisRegisters{100, 102, 103, 100, 101, 102, 104, 105},
                                    AxisRegisters{200, 202, 203, 200, 201, 202, 204, 205}};
  double angle_lsb_deg = 0.0001;  // one count of a 32-bit angle
  double speed_lsb_dps = 0.01;    // one count of the 16-bit speed
  WordOrder word_order = WordOrder::high_first;

  const AxisRegisters& axis(StandAxis a) const { return axes[static_cast<int>(a) - 1]; }
  // Highest register address used + 1, per table (sizes the emulator's tables).
  int holding_size() const;
  int input_size() const;
};

inline constexpr std::uint16_t kMapVersion = 1;

// Axis command register values. The controller clears the register when it has acted.
enum class AxisCommand : std::uint16_t {
  none = 0,
  enable = 1,
  disable = 2,
  home = 3,
  move = 4,
  stop = 5
};
// Global command register values.
enum class GlobalCommand : std::uint16_t { none = 0, emergency_stop = 1, reset = 2 };
// Axis state register values; the order of AxisMode.
enum class StateCode : std::uint16_t {
  disabled = 0,
  idle = 1,
  homing = 2,
  moving = 3,
  in_position = 4,
  fault = 5
};
// Axis flag bits.
inline constexpr std::uint16_t kFlagEnabled = 1u << 0;
inline constexpr std::uint16_t kFlagHomed = 1u << 1;
inline constexpr std::uint16_t kFlagStoppedByHeartbeat = 1u << 2;
inline constexpr std::uint16_t kFlagEstop = 1u << 3;
// Global flag bits.
inline constexpr std::uint16_t kGlobalEstop = 1u << 0;
inline constexpr std::uint16_t kGlobalHeartbeatLost = 1u << 1;
// Fault codes.
inline constexpr int kFaultFollowing = 1;
inline constexpr int kFaultSoftLimit = 2;
inline constexpr int kFaultDrive = 3;
inline constexpr int kFaultHoming = 4;
// What a fault code means, for an operator.
const char* fault_text(int code);

// 32-bit values over two registers in the configured word order.
void put_i32(std::uint16_t* regs, std::int32_t value, WordOrder order);
std::int32_t get_i32(const std::uint16_t* regs, WordOrder order);
// Angle ↔ counts; an angle that does not fit 32 bits gives invalid_argument.
Result<std::int32_t> angle_to_counts(const RegisterMap& map, double angle_deg);
double counts_to_angle_deg(const RegisterMap& map, std::int32_t counts);

// Timing of the link: retries, back-off, heartbeat.
struct LinkTiming {
  double timeout_s = 0.3;            // response timeout of one request
  int tries = 3;                     // attempts of one request before the link is re-opened
  double backoff_first_s = 0.1;      // first wait before re-opening a failed link
  double backoff_max_s = 2.0;        // the wait doubles up to this
  double heartbeat_period_s = 0.1;   // how often the driver writes the heartbeat
  double heartbeat_timeout_s = 1.0;  // written to the controller: stop motion after this silence
};

// The warning of a timing whose heartbeat can stall past the controller's watchdog while a
// request is still being retried ("" when it cannot). The I/O thread writes the heartbeat
// between requests, so a request whose replies are lost holds it for up to tries x timeout_s
// after a period: past heartbeat_timeout_s the controller stops the axes while the driver
// still counts the link up, and a glitch it would ride out ends the move (a stop, but one
// that reads as "stopped by heartbeat" rather than as the lost replies it was).
std::string heartbeat_margin_warning(const LinkTiming& timing);
// How long a request whose replies are all lost holds the heartbeat: a period, then tries x
// timeout_s.
double heartbeat_held_s(const LinkTiming& timing);
// The warning of a watchdog switched off (heartbeat_timeout_s 0), "" when it is on: fine for
// `standcal stand move --no-wait` at bring-up, but a service that drives the stand unattended
// (standcald) then leaves it moving to its target when it dies. Not among parse_config's
// warnings: whoever runs unattended says it (standcald at start, `standcal doctor`).
std::string watchdog_off_warning(const LinkTiming& timing);

// Everything a Modbus stand needs besides its URL: the map, timing, axis ranges, speed.
struct ModbusStandConfig {
  RegisterMap map;
  LinkTiming timing;
  std::array<AxisRange, 2> ranges{};  // limited ±180° unless configured (calib/axis_range.hpp)
  double speed_dps = 10.0;            // commanded speed of moves; 0 leaves the controller's default
  double enable_timeout_s = 2.0;      // how long enable() waits for the drive to report enabled
  // What parse_config accepted but an operator should hear of (heartbeat_margin_warning);
  // load_config prefixes the file's path. Each caller says them where it reports.
  std::vector<std::string> warnings;
};

// What a service that drives the stand unattended (standcald; `standcal doctor` for it) says
// of `config` as read from `path` ("" for the defaults): its own warnings, and a watchdog
// switched off, each naming the file.
std::vector<std::string> unattended_warnings(const ModbusStandConfig& config,
                                             const std::string& path);

// Reads a config from JSON (docs/stand-modbus.md "Config keys"); absent keys keep defaults,
// unknown keys are an error naming them.
Result<ModbusStandConfig> parse_config(const nlohmann::json& json);
// Reads the JSON file at `path`, or the defaults when `path` is empty.
Result<ModbusStandConfig> load_config(const std::string& path);

}  // namespace standcal::drivers::modbus
