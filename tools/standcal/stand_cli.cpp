// `standcal stand`: bring-up commands for an engineer wiring a new stand over Modbus.
//   standcal stand --url URL status [--json] | enable | home | move A1_DEG A2_DEG | stop | estop |
//   reset
// home and move wait (the driver's I/O thread keeps the heartbeat alive meanwhile) and
// print the angles reached; --no-wait returns once the controller accepted the command.
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/json_text.hpp"
#include "drivers/modbus/modbus_stand.hpp"
#include "drivers/stand.hpp"
#include "tools/standcal/commands.hpp"

namespace standcal::cli {

namespace {

namespace drv = standcal::drivers;

struct StandOptions {
  std::string url;
  std::string config_path;
  bool no_wait = false;
  bool json = false;
  double timeout_s = 120.0;
  double window_deg = 0.001;
  double dwell_s = 0.3;
  double a1_deg = 0.0;
  double a2_deg = 0.0;
};

constexpr drv::StandAxis kAxes[] = {drv::StandAxis::outer, drv::StandAxis::inner};

void check(const drv::Status& status) {
  if (!status) throw std::runtime_error(status.message);
}

template <class T>
T check(drv::Result<T> result) {
  if (!result) throw std::runtime_error(result.status().message);
  return std::move(result.value());
}

// Opens the stand and brings it to inactive (link up, readable); `active` also allows motion.
std::unique_ptr<drv::modbus::ModbusStand> open_stand(const StandOptions& o, bool active) {
  auto config = check(drv::modbus::load_config(o.config_path));
  for (const std::string& warning : config.warnings)
    std::fprintf(stderr, "warning: %s\n", warning.c_str());
  auto stand = check(drv::modbus::ModbusStand::create(o.url, config));
  check(stand->configure());
  if (active) check(stand->activate());
  return stand;
}

void print_angles(const double* angles_deg, const char* suffix) {  // outer, inner
  std::printf("outer %.4f° inner %.4f°%s\n", angles_deg[0], angles_deg[1], suffix);
}

void print_status(const StandOptions& o) {
  auto stand = open_stand(o, false);
  nlohmann::json axes;
  for (auto axis : kAxes) {
    const auto s = check(stand->read_state(axis));
    if (!o.json) {
      std::printf("%s: %s %.4f°%s%s%s%s", drv::to_string(axis), drv::to_string(s.mode), s.angle_deg,
                  s.enabled ? " enabled" : " disabled", s.homed ? " homed" : " not-homed",
                  s.stopped_by_heartbeat ? " stopped-by-heartbeat" : "", s.estop ? " ESTOP" : "");
      if (s.fault_code != 0) std::printf(" fault %d (%s)", s.fault_code, s.fault_text.c_str());
      std::printf("\n");
    }
    axes[drv::to_string(axis)] = {{"mode", drv::to_string(s.mode)},
                                  {"angle_deg", s.angle_deg},
                                  {"enabled", s.enabled},
                                  {"homed", s.homed},
                                  {"stopped_by_heartbeat", s.stopped_by_heartbeat},
                                  {"estop", s.estop},
                                  {"fault_code", s.fault_code},
                                  {"fault_text", s.fault_text}};
  }
  if (o.json) {
    const nlohmann::json out = {
        {"class", "STAND"}, {"url", o.url}, {"stand", stand->name()}, {"axes", axes}};
    std::printf("%s\n", json_text(out, -1).c_str());
  }
}

void enable(const StandOptions& o) {
  auto stand = open_stand(o, true);
  for (auto axis : kAxes) check(stand->enable(axis));
  std::printf("outer enabled, inner enabled\n");
}

void note_no_wait(const StandOptions& o) {
  std::printf(
      "accepted; not waiting. Note: the controller stops this motion when the heartbeat "
      "timeout (config timing.heartbeat_timeout_s%s) passes after this command exits.\n",
      o.config_path.empty() ? ", default 1 s" : "");
}

void home(const StandOptions& o) {
  auto stand = open_stand(o, true);
  for (auto axis : kAxes) check(stand->home(axis));
  if (o.no_wait) return note_no_wait(o);
  const std::vector<double> reached = check(drv::wait_homed(*stand, kAxes, o.timeout_s, 0.02));
  print_angles(reached.data(), " (homed)");
  check(stand->deactivate());
}

void move(const StandOptions& o) {
  auto stand = open_stand(o, true);
  const double targets[2] = {o.a1_deg, o.a2_deg};
  std::vector<drv::AxisTarget> normalised;
  for (int i = 0; i < 2; ++i) {
    const double now_deg = check(stand->read_angle_deg(kAxes[i]));
    normalised.push_back(
        {kAxes[i], check(drv::normalise_target_deg(stand->range(kAxes[i]), targets[i], now_deg))});
    check(stand->move_to(kAxes[i], targets[i]));
  }
  if (o.no_wait) return note_no_wait(o);
  const drv::InPositionRule rule{o.window_deg, o.dwell_s, o.timeout_s, 0.02};
  const std::vector<double> reached = check(drv::wait_in_position(*stand, normalised, rule));
  print_angles(reached.data(), "");
  check(stand->deactivate());
}

void stop(const StandOptions& o) {
  auto stand = open_stand(o, false);
  for (auto axis : kAxes) check(stand->stop(axis));
  std::printf("outer stopping, inner stopping\n");
}

void estop(const StandOptions& o) {
  auto stand = open_stand(o, false);
  check(stand->emergency_stop());
  std::printf("emergency stop commanded: both axes stopped and disabled\n");
}

void reset(const StandOptions& o) {
  auto stand = open_stand(o, false);
  if (stand->lifecycle() == drv::Lifecycle::error) check(stand->recover());
  std::printf("emergency stop reset; enable the axes again to move\n");
}

void add_stand_commands(CLI::App& app) {
  auto options = std::make_shared<StandOptions>();
  auto* stand = app.add_subcommand("stand", "bring-up of a stand controller over Modbus");
  stand->require_subcommand(1);
  stand
      ->add_option("--url", options->url,
                   "tcp://HOST:PORT?unit=1 or rtu:/dev/ttyUSB0?baud=115200&parity=N&unit=1&rs485=1")
      ->required();
  stand->add_option("--config", options->config_path,
                    "stand config JSON (register map, timing, axis ranges)");
  stand->add_option("--timeout-s", options->timeout_s, "how long home/move wait");
  stand->add_option("--window-deg", options->window_deg, "in-position window");
  stand->add_option("--dwell-s", options->dwell_s, "in-position dwell");
  auto* status = stand->add_subcommand("status", "mode, angle, flags and fault of both axes");
  status->add_flag("--json", options->json, "one JSON object on one line");
  status->callback([options] { print_status(*options); });
  stand->add_subcommand("enable", "activate and enable both axes")->callback([options] {
    enable(*options);
  });
  auto* home_cmd = stand->add_subcommand("home", "home both axes and wait");
  home_cmd->add_flag("--no-wait", options->no_wait,
                     "return once the controller accepted the command");
  home_cmd->callback([options] { home(*options); });
  auto* move_cmd =
      stand->add_subcommand("move", "move outer to A1_DEG and inner to A2_DEG and wait");
  move_cmd->add_option("A1_DEG", options->a1_deg, "outer axis angle α1")->required();
  move_cmd->add_option("A2_DEG", options->a2_deg, "inner axis angle α2")->required();
  move_cmd->add_flag("--no-wait", options->no_wait,
                     "return once the controller accepted the command");
  move_cmd->callback([options] { move(*options); });
  stand->add_subcommand("stop", "controlled stop of both axes")->callback([options] {
    stop(*options);
  });
  stand->add_subcommand("estop", "emergency stop of both axes")->callback([options] {
    estop(*options);
  });
  stand->add_subcommand("reset", "clear a latched emergency stop")->callback([options] {
    reset(*options);
  });
}

}  // namespace

static const bool stand_commands_registered = register_command_group(add_stand_commands);

}  // namespace standcal::cli
