#pragma once
// standcald's configuration (docs/daemon.md lists every key): where it listens, where it
// keeps its state, which backend drives the stand and the unit, and the run defaults.
// A bad file fails at start with a ConfigError naming the key and the reason.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

#include "calib/noise_model.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/uncertainty_budget.hpp"
#include "drivers/stand.hpp"
#include "protocol/jsonrpc/paths.hpp"

namespace standcal::daemon {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SimSettings {
  double time_scale = 1;  // simulated seconds per real second
  std::uint64_t seed = 1;
  double move_rate_deg_s = 10;
  std::string truth_file;  // standcal-model/1 JSON; empty = calib's default truth
};

// When a position's samples are good enough to keep (else re-measure, then fault).
struct StabilityRule {
  double sigma_limit_ug = 5000;  // per-axis sample sigma above this: too noisy
  double trend_limit_ug = 2000;  // per-axis drift over the dwell (linear fit) above this
  // Per-axis drift over the dwell above this many times what the unit's noise explains
  // (white noise of the dwell's own residual sigma, widened for its samples' correlation
  // as the run's dwells pooled show it, plus the configured bias wander): a
  // drift the noise model cannot account for (thermal or mechanical settling). 0: off.
  double trend_limit_sigmas = 0;
  double min_sample_fraction = 0.9;  // fewer samples than this share of dwell x rate: incomplete
  int remeasure_max = 2;             // re-measurements before the run faults
};

// The most samples a dwell or unit.read holds at once (48 bytes each: 190 MB): a dwell is
// judged whole by the stability rule, and averaged whole. 10 h at 100 Hz; 66 min at 1 kHz.
inline constexpr double kMaxDwellSamples = 4e6;
// The most samples a warm-up may have. The sequencer writes it as it comes, but the run's fit
// reads position 1's block whole for its Allan curves (about 50 bytes a row: VmHWM 179 MB for
// 3.6 M rows, docs/reliability.md): 500 MB. Any warm-up at 100 Hz (27.8 h); 2.8 h at 1 kHz. The
// thermal wait's windows are taken as they come and have no bound.
inline constexpr double kMaxWarmupSamples = 1e7;
// The most seconds `samples` last at rate_hz, rounded down to the six significant digits the
// messages print, so that the figure a refusal suggests is itself accepted.
double most_seconds_of(double samples, double rate_hz);

// Optional wait for thermal stability before the first position.
struct ThermalWait {
  bool enabled = false;
  double rate_limit_c_per_min = 0.05;
  double window_s = 60;
  double timeout_s = 3600;
};

struct DaemonConfig {
  std::string source = "(built-in defaults)";          // file the config came from
  nlohmann::json document = nlohmann::json::object();  // as read, for the configuration hash
  // Server.
  std::string socket_path = paths::kSocket;
  std::string socket_group;     // empty: leave the group of the socket file alone
  unsigned socket_mode = 0660;  // socket.mode, given as an octal string ("0660")
  bool tcp_enabled = false;     // TCP listener
  int tcp_port = 0;             // 0: any free port (logged)
  std::string tcp_bind =
      "127.0.0.1";             // numeric IPv4/IPv6 address; not loopback: needs tcp_token_file
  std::string tcp_token_file;  // the shared secret TCP clients send with `auth` (docs/security.md)
  std::string control_group;   // access.control_group: empty = every Unix-socket peer may command
  int max_clients = 256;
  std::size_t client_queue_bytes = 1024 * 1024;  // unsent output per client before it is dropped
  // A request line begun but not ended within this is dropped with its connection, so a
  // client trickling bytes cannot hold a slot (docs/security.md).
  double client_request_timeout_s = 10;
  // A connection with no request, no answer pending and no event subscription for this
  // long is closed.
  double client_idle_timeout_s = 600;
  std::string state_dir = paths::kStateDir;
  std::string db_url;  // records database (docs/records.md); empty: STATE/records.sqlite
  std::string log_level = "info";
  // Hardware.
  std::string stand_backend = "sim";  // "sim" | "modbus"
  std::string unit_backend = "sim";   // "sim" | "socketcan"
  // Whether stand.backend / unit.backend were given (in the file, or by --sim): the daemon
  // never runs on the simulator because a section was left out (require_named_backends).
  bool stand_backend_named = false;
  bool unit_backend_named = false;
  std::string stand_id = "sim-stand";
  std::string modbus_url;              // stand.url for "modbus"
  std::string modbus_map_file;         // stand.register_map: a register-map JSON file (optional)
  std::string can_interface = "can0";  // unit.interface for "socketcan"
  std::string can_layout_file;         // unit.layout: a frame-layout JSON file (optional)
  double sample_rate_hz = 100;         // unit.sample_rate_hz: the unit's output rate
  // unit.bias_instability_ug / _tau_s: the unit's known Gauss-Markov bias wander (data sheet,
  // earlier runs), which fits and diagnoses assume when a run alone does not show one; size 0:
  // none. unit.bias_instability_tau_s present: the fits take it as known (known_tau), up to
  // unit.bias_instability_tau_max_s when that is there too (the range `standcal noise` gives
  // from a static recording). A run's recording carries it in its header, which its fits read.
  GivenWander unit_wander;
  // unit.static_recording: a long static recording of the unit (g or m/s^2, as `standcal
  // noise` reads it), read and fitted once at start. Where unit.bias_instability_* is not
  // configured (both are refused), the wander its Allan curves pin is unit_wander, and each
  // run's header says where it came from (kHeaderUnitWanderSource); where they show none,
  // unit_static_curves_ug, and where they see one they do not pin, unit_static_tau_floor_s.
  // What it gave, and why, is logged at start.
  std::string unit_static_recording_file;
  // unit.static_recording_input: how that file is read (format, columns, rate_hz, skip_lines,
  // units, as `standcal noise` and `--unit-static-*` take them; no g: run.g_local_mps2 puts it
  // in ug); automatic by default, and the reader's messages name these keys.
  InputOptions unit_static_recording_input;
  std::optional<UnitStaticRecordingUse> unit_static_recording;
  // Its Allan curves, where they show no wander and reach the wanders the fits model: each
  // run's header carries them (kHeaderUnitStaticCurves), and every fit of the run weighs them
  // as a bound on the wander its sigmas allow for, as `standcal fit --unit-static-recording`.
  std::optional<WanderCurves> unit_static_curves_ug;
  // Where its curves see a wander they do not pin, the floor they put under its correlation
  // time (s; 0: none): each run's header carries it (kHeaderUnitStaticTauFloorS), and every fit
  // of the run takes it where the run shows the wander at those times.
  double unit_static_tau_floor_s = 0;
  SimSettings sim;
  AxisRange outer;  // limited ±180° unless configured
  AxisRange inner;
  drivers::InPositionRule in_position{0.001, 0.3, 120.0, 0.02};
  double home_timeout_s = 180;
  // Run defaults.
  double settle_s = 5;
  double dwell_s = 60;
  double g_local_mps2 = 9.81625;
  std::string g_source = "configured value (set run.g_local_mps2 and run.g_source for this site)";
  StabilityRule stability;
  ThermalWait thermal;
  // run.budget: a standcal-budget/1 file, read at start; every run's result then carries
  // the GUM uncertainty budget of its joint fit (docs/calibration.md "Uncertainty budget").
  std::string budget_file;
  std::optional<BudgetConfig> budget;
  std::string program_library_dir;  // "NAME" -> DIR/NAME.json
};

// Reads and checks a JSON config file; throws ConfigError("FILE: KEY: reason").
DaemonConfig load_config(const std::string& path);
// Parses a config document (`source` names it in errors).
DaemonConfig parse_config(const nlohmann::json& doc, const std::string& source);
// Throws ConfigError unless the stand's and the unit's backends were both named: a lab
// config that forgot its "stand" section must not calibrate a simulated stand.
void require_named_backends(const DaemonConfig& config);
// Built-in defaults with the simulated backend (standcald --sim).
DaemonConfig sim_config(const std::string& socket_path, const std::string& state_dir,
                        double time_scale);
// Whether `address` (numeric IPv4 or IPv6) is a loopback address (127.0.0.0/8, ::1).
bool is_loopback_address(const std::string& address);
// Reads the TCP token from config.tcp_token_file; throws ConfigError naming the file when
// it is missing, too short (< 16 characters) or readable by every user.
std::string load_tcp_token(const DaemonConfig& config);

// A short stable hash of the effective configuration, for traceability.
std::string config_hash(const DaemonConfig& config);

}  // namespace standcal::daemon
