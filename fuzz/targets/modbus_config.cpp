// The stand config reader (drivers/modbus/register_map.hpp parse_config, docs/stand-modbus.md
// "Config keys"). It returns a Result, so no exception may escape. Properties: every
// register address the file gives is the address the map uses (nothing silently wrapped
// into the 16-bit register space), and the emulator's table sizes cover every register.
#include <nlohmann/json.hpp>
#include <string>

#include "drivers/modbus/register_map.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace modbus = standcal::drivers::modbus;
using nlohmann::json;

namespace {

// The address the file gave for `key` must be the one the map holds.
void check_address(const json& section, const char* key, std::uint16_t parsed,
                   const std::string& where) {
  if (!section.is_object() || !section.contains(key) || !section[key].is_number()) return;
  const double given = section[key].get<double>();
  standcal::fuzz::require(given == static_cast<double>(parsed),
                          "modbus_config: register " + where + key + " given as " +
                              section[key].dump() + " was accepted as address " +
                              std::to_string(parsed));
}

void check_axis(const json& registers, const char* name, const modbus::AxisRegisters& a) {
  if (!registers.contains(name)) return;
  const json& s = registers[name];
  const std::string where = std::string(name) + ".";
  check_address(s, "target", a.target, where);
  check_address(s, "speed", a.speed, where);
  check_address(s, "command", a.command, where);
  check_address(s, "state", a.state, where);
  check_address(s, "flags", a.flags, where);
  check_address(s, "angle", a.angle, where);
  check_address(s, "fault", a.fault, where);
  check_address(s, "command_count", a.command_count, where);
}

void check_sizes(const modbus::RegisterMap& map) {
  const int holding = map.holding_size();
  const int input = map.input_size();
  auto covered = [](int address, int size, const char* what) {
    standcal::fuzz::require(address < size, std::string("modbus_config: table size ") +
                                                std::to_string(size) + " does not cover " + what +
                                                " at " + std::to_string(address));
  };
  covered(map.heartbeat, holding, "heartbeat");
  covered(map.global_command, holding, "global_command");
  covered(map.global_flags, input, "global_flags");
  covered(map.map_version, input, "map_version");
  for (const auto& a : map.axes) {
    covered(a.target + 1, holding, "target (2nd word)");
    covered(a.command, holding, "command");
    covered(a.angle + 1, input, "angle (2nd word)");
    covered(a.command_count, input, "command_count");
  }
}

}  // namespace

int standcal_fuzz_modbus_config(const std::uint8_t* data, std::size_t size) {
  const auto doc = json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: load_config rejects it before parse_config
  return standcal::fuzz::expect_no_exceptions("modbus_config", [&] {
    const auto config = modbus::parse_config(doc);
    if (!config) return;
    const modbus::RegisterMap& map = config.value().map;
    if (doc.contains("registers") && doc["registers"].is_object()) {
      const json& r = doc["registers"];
      check_address(r, "heartbeat", map.heartbeat, "");
      check_address(r, "heartbeat_timeout_ms", map.heartbeat_timeout_ms, "");
      check_address(r, "global_command", map.global_command, "");
      check_address(r, "global_flags", map.global_flags, "");
      check_address(r, "map_version", map.map_version, "");
      check_axis(r, "outer", map.axes[0]);
      check_axis(r, "inner", map.axes[1]);
    }
    check_sizes(map);
  });
}
