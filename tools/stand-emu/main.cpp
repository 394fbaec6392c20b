// standcal-stand-emu: an emulated two-axis stand controller speaking the register map of
// docs/stand-modbus.md over Modbus TCP or RTU, for tests and bring-up without hardware.
// The first line on stdout is the URL clients connect to (with --listen port 0, the port
// the system picked).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <exception>
#include <sstream>

#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/url.hpp"
#include "standcal/version.hpp"
#include "tools/cli_checks.hpp"
#include "tools/stand-emu/emulator.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;

void on_signal(int) { g_stop = 1; }

// "outer:-90:90" → soft limits of that axis.
void apply_soft_limit(const std::string& text, std::array<standcal::emu::AxisModel, 2>& axes) {
  std::istringstream in(text);
  std::string axis;
  double low = 0, high = 0;
  char colon = 0;
  if (!std::getline(in, axis, ':') || !(in >> low >> colon >> high) || colon != ':' ||
      low >= high || (axis != "outer" && axis != "inner"))
    throw std::runtime_error("bad --soft-limit '" + text + "' (use outer:-90:90)");
  auto& model = axes[axis == "outer" ? 0 : 1];
  model.soft_min_deg = low;
  model.soft_max_deg = high;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"standcal-stand-emu: an emulated stand controller (Modbus TCP/RTU server)"};
  app.set_version_flag("--version", standcal::kVersionLine);
  std::string listen, config_path, control;
  std::vector<std::string> soft_limits, fault_lines;
  standcal::emu::EmulatorOptions options;
  double max_speed_dps = 30.0, accel_dps2 = 90.0, noise_deg = 0.00003;
  app.add_option("--listen", listen,
                 "tcp://IP:PORT (port 0: any free port) or rtu:/dev/tty...?baud=..&unit=..")
      ->required();
  app.add_option("--config", config_path,
                 "stand config JSON: its register map and scaling are served");
  app.add_option("--time-scale", options.time_scale,
                 "simulated seconds per real second (speeds up motion)")
      ->check(standcal::cli_checks::kPositive);
  app.add_option("--max-speed-dps", max_speed_dps, "rate limit of both axes, °/s")
      ->check(standcal::cli_checks::kPositive);
  app.add_option("--accel-dps2", accel_dps2, "acceleration limit of both axes, °/s²")
      ->check(standcal::cli_checks::kPositive);
  app.add_option("--noise-deg", noise_deg, "encoder noise, 1σ in degrees")
      ->check(standcal::cli_checks::kNonNegative);
  app.add_option("--start-outer-deg", options.start_deg[0], "outer axis angle at power-up");
  app.add_option("--start-inner-deg", options.start_deg[1], "inner axis angle at power-up");
  app.add_option("--soft-limit", soft_limits,
                 "AXIS:MIN:MAX soft limits of commanded angles, e.g. inner:-170:170");
  app.add_option("--heartbeat-timeout-ms", options.heartbeat_timeout_ms,
                 "initial watchdog timeout (0: off)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--fault", fault_lines,
                 "inject a fault: 'stuck AXIS', 'slow AXIS F', 'overshoot AXIS DEG', 'drive_fault "
                 "AXIS', 'delay_ms N [N]', "
                 "'exception CODE [N]', 'drop [N]', 'corrupt [N]'");
  app.add_option("--control", control,
                 "control file of fault lines, re-read when it changes (replaces --fault)");
  app.add_option("--status-file", options.status_file,
                 "write the axes' state, flags, angle and fault registers here every 50 ms");
  app.add_option("--seed", options.seed, "seed of the encoder noise");
  CLI11_PARSE(app, argc, argv);
  try {
    auto url = standcal::drivers::modbus::parse_url(listen);
    if (!url) throw std::runtime_error(url.status().message);
    options.listen = url.value();
    auto config = standcal::drivers::modbus::load_config(config_path);
    if (!config) throw std::runtime_error(config.status().message);
    options.map = config.value().map;
    for (auto& model : options.axes) {
      model.max_speed_dps = max_speed_dps;
      model.accel_dps2 = accel_dps2;
      model.encoder_noise_deg = noise_deg;
      model.encoder_lsb_deg = options.map.angle_lsb_deg;
    }
    for (const auto& text : soft_limits) apply_soft_limit(text, options.axes);
    std::string error;
    if (!standcal::emu::parse_faults(fault_lines, options.faults, error))
      throw std::runtime_error(error);
    options.control_file = control;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGPIPE, SIG_IGN);
    standcal::emu::Emulator emulator(options);
    std::printf("%s\n", emulator.open().c_str());
    std::fflush(stdout);
    emulator.run(g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "standcal-stand-emu: %s\n", e.what());
    return 1;
  }
  return 0;
}
