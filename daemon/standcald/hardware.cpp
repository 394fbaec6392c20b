#include "daemon/standcald/hardware.hpp"

#include <charconv>
#include <string_view>

#include "calib/simulator.hpp"
#ifdef STANDCAL_HAVE_SIM
#include "drivers/sim/sim_backend.hpp"
#endif
#ifdef STANDCAL_HAVE_MODBUS
#include "drivers/modbus/modbus_stand.hpp"
#endif
#ifdef STANDCAL_HAVE_SOCKETCAN
#include "drivers/socketcan/socketcan_unit.hpp"
#endif

namespace standcal::daemon {

namespace {

[[noreturn, maybe_unused]] void unavailable(const DaemonConfig& c, const std::string& key,
                                            const std::string& backend) {
  throw ConfigError(c.source + ": " + key + ": backend \"" + backend +
                    "\" is not built into this standcald");
}

#ifdef STANDCAL_HAVE_MODBUS
std::shared_ptr<drivers::Stand> make_modbus_stand(const DaemonConfig& c,
                                                  std::vector<std::string>& warnings) {
  drivers::modbus::ModbusStandConfig mc;
  if (!c.modbus_map_file.empty()) {
    auto loaded = drivers::modbus::load_config(c.modbus_map_file);
    if (!loaded) throw ConfigError(c.source + ": stand.register_map: " + loaded.status().message);
    mc = loaded.value();
  }
  for (const std::string& warning : drivers::modbus::unattended_warnings(mc, c.modbus_map_file))
    warnings.push_back(c.source + ": stand.register_map: " + warning);
  mc.ranges[0] = c.outer;
  mc.ranges[1] = c.inner;
  auto stand = drivers::modbus::ModbusStand::create(c.modbus_url, mc);
  if (!stand) throw ConfigError(c.source + ": stand.url: " + stand.status().message);
  return std::shared_ptr<drivers::Stand>(std::move(stand.value()));
}
#endif

#ifdef STANDCAL_HAVE_SOCKETCAN
// unit.interface "fd:N": N whole, a descriptor number (std::stoi took "fd:3x" and said
// only "stoi" for "fd:x").
int inherited_fd(const DaemonConfig& c) {
  const std::string_view digits = std::string_view(c.can_interface).substr(3);
  int fd = -1;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), fd);
  if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size() || fd < 0) {
    throw ConfigError(
        c.source + ": unit.interface: \"" + c.can_interface +
        "\" must be a CAN interface name or fd:N with N an inherited descriptor number");
  }
  return fd;
}

std::shared_ptr<drivers::AccelUnit> make_can_unit(const DaemonConfig& c) {
  auto layout = drivers::can::FrameLayout::default_layout();
  if (!c.can_layout_file.empty()) {
    // JSON or DBC (docs/unit-can.md); the reader names the file and what is wrong.
    auto parsed = drivers::can::FrameLayout::from_file(c.can_layout_file);
    if (!parsed) throw ConfigError(c.source + ": unit.layout: " + parsed.status().message);
    layout = parsed.value();
  }
  const std::string& iface = c.can_interface;
  auto unit = iface.rfind("fd:", 0) == 0
                  ? drivers::can::SocketCanUnit::adopt_fd(inherited_fd(c), layout)
                  : drivers::can::SocketCanUnit::open(iface, layout);
  if (!unit) throw ConfigError(c.source + ": unit.interface: " + unit.status().message);
  return std::shared_ptr<drivers::AccelUnit>(std::move(unit.value()));
}
#endif

}  // namespace

Hardware make_hardware(const DaemonConfig& c) {
  Hardware hw;
  if (c.stand_backend == "sim" || c.unit_backend == "sim") {
#ifdef STANDCAL_HAVE_SIM
    drivers::SimBackendConfig sc;
    if (!c.sim.truth_file.empty()) {
      try {
        sc.truth = load_truth(c.sim.truth_file);
      } catch (const std::exception& e) {
        throw ConfigError(c.source + ": sim.truth: " + e.what());
      }
    }
    sc.sample_rate_hz = c.sample_rate_hz;
    sc.time_scale = c.sim.time_scale;
    sc.seed = c.sim.seed;
    sc.outer = c.outer;
    sc.inner = c.inner;
    sc.move_rate_deg_s = c.sim.move_rate_deg_s;
    drivers::SimBackend sim = drivers::make_sim_backend(sc);
    if (c.stand_backend == "sim") hw.stand = sim.stand;
    if (c.unit_backend == "sim") hw.unit = sim.unit;
    if (c.stand_backend == "sim" && c.unit_backend == "sim") hw.remount = sim.remount;
    // A real stand and a simulated unit do not share a clock: time runs at 1x.
    if (c.stand_backend == "sim") hw.clock = sim.clock;
    hw.description = "sim (time x" + std::to_string(c.sim.time_scale) + ")";
#else
    unavailable(c, c.stand_backend == "sim" ? "stand.backend" : "unit.backend", "sim");
#endif
  }
  if (c.stand_backend == "modbus") {
#ifdef STANDCAL_HAVE_MODBUS
    hw.stand = make_modbus_stand(c, hw.warnings);
    hw.description += (hw.description.empty() ? "" : " + ") + std::string("modbus ") + c.modbus_url;
#else
    unavailable(c, "stand.backend", "modbus");
#endif
  }
  if (c.unit_backend == "socketcan") {
#ifdef STANDCAL_HAVE_SOCKETCAN
    hw.unit = make_can_unit(c);
    hw.description +=
        (hw.description.empty() ? "" : " + ") + std::string("socketcan ") + c.can_interface;
#else
    unavailable(c, "unit.backend", "socketcan");
#endif
  }
  return hw;
}

}  // namespace standcal::daemon
