// The register map's encoding and its JSON config.
#include "drivers/modbus/register_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <string_view>

namespace standcal::drivers::modbus {

namespace {

using nlohmann::json;

Status config_error(const std::string& why) {
  return Status::error(ErrorKind::invalid_argument, "stand config: " + why);
}

// Empty when every key of `object` is one of `known`, else the message naming the stray key.
std::string unknown_key(const json& object, std::string_view where,
                        std::initializer_list<std::string_view> known) {
  for (const auto& [key, value] : object.items()) {
    if (std::find(known.begin(), known.end(), key) == known.end())
      return "unknown key '" + key + "' in " + std::string(where);
  }
  return {};
}

// A register address must be a whole number 0..65535: a larger or fractional value
// must not wrap into another register (found by fuzz/regressions/modbus_config).
void read_address(const json& object, const char* key, std::uint16_t& out) {
  if (!object.contains(key)) return;
  const json& v = object.at(key);
  if (!v.is_number_integer() ||
      (v.is_number_unsigned() ? v.get<std::uint64_t>() > 65535
                              : v.get<std::int64_t>() < 0 || v.get<std::int64_t>() > 65535))
    throw json::out_of_range::create(
        406, std::string("register ") + key + " must be a whole number 0..65535, got " + v.dump(),
        nullptr);
  out = static_cast<std::uint16_t>(v.get<std::int64_t>());
}

// A whole number in [min, max]: json's get<int> would wrap 4294967297 to 1 (one try).
void read_count(const json& object, const char* key, int min, int max, int& out) {
  if (!object.contains(key)) return;
  const json& v = object.at(key);
  // Compared as unsigned when json holds it so: 2^64 - 1 is no int64.
  const bool in_range =
      v.is_number_integer() &&
      (v.is_number_unsigned() ? v.get<std::uint64_t>() >= std::uint64_t(min) &&
                                    v.get<std::uint64_t>() <= std::uint64_t(max)
                              : v.get<std::int64_t>() >= min && v.get<std::int64_t>() <= max);
  if (!in_range)
    throw json::out_of_range::create(406,
                                     std::string(key) + " must be a whole number " +
                                         std::to_string(min) + ".." + std::to_string(max) +
                                         ", got " + v.dump(),
                                     nullptr);
  out = static_cast<int>(v.get<std::int64_t>());
}

template <class T>
void read_value(const json& object, const char* key, T& out) {
  if (object.contains(key)) out = object.at(key).get<T>();
}

std::string parse_axis_registers(const json& j, const std::string& where, AxisRegisters& r) {
  if (auto why = unknown_key(
          j, where,
          {"target", "speed", "command", "state", "flags", "angle", "fault", "command_count"});
      !why.empty())
    return why;
  read_address(j, "target", r.target);
  read_address(j, "speed", r.speed);
  read_address(j, "command", r.command);
  read_address(j, "state", r.state);
  read_address(j, "flags", r.flags);
  read_address(j, "angle", r.angle);
  read_address(j, "fault", r.fault);
  read_address(j, "command_count", r.command_count);
  return {};
}

std::string parse_registers(const json& j, RegisterMap& map) {
  if (auto why = unknown_key(j, "registers",
                             {"heartbeat", "heartbeat_timeout_ms", "global_command", "global_flags",
                              "map_version", "outer", "inner"});
      !why.empty())
    return why;
  read_address(j, "heartbeat", map.heartbeat);
  read_address(j, "heartbeat_timeout_ms", map.heartbeat_timeout_ms);
  read_address(j, "global_command", map.global_command);
  read_address(j, "global_flags", map.global_flags);
  read_address(j, "map_version", map.map_version);
  if (j.contains("outer")) {
    if (auto why = parse_axis_registers(j.at("outer"), "registers.outer", map.axes[0]);
        !why.empty())
      return why;
  }
  if (j.contains("inner")) {
    if (auto why = parse_axis_registers(j.at("inner"), "registers.inner", map.axes[1]);
        !why.empty())
      return why;
  }
  return {};
}

std::string parse_timing(const json& j, LinkTiming& t) {
  if (auto why = unknown_key(j, "timing",
                             {"timeout_s", "tries", "backoff_first_s", "backoff_max_s",
                              "heartbeat_period_s", "heartbeat_timeout_s"});
      !why.empty())
    return why;
  read_value(j, "timeout_s", t.timeout_s);
  read_count(j, "tries", 1, 1000, t.tries);
  read_value(j, "backoff_first_s", t.backoff_first_s);
  read_value(j, "backoff_max_s", t.backoff_max_s);
  read_value(j, "heartbeat_period_s", t.heartbeat_period_s);
  read_value(j, "heartbeat_timeout_s", t.heartbeat_timeout_s);
  if (t.timeout_s <= 0 || t.tries < 1 || t.backoff_first_s < 0 ||
      t.backoff_max_s < t.backoff_first_s || t.heartbeat_period_s <= 0 ||
      t.heartbeat_timeout_s < 0 || t.heartbeat_timeout_s > 65.535)
    return "timing: need timeout_s > 0, tries >= 1, 0 <= backoff_first_s <= backoff_max_s, "
           "heartbeat_period_s > 0, 0 <= heartbeat_timeout_s <= 65.535";
  return {};
}

std::string parse_range(const json& j, const std::string& where, AxisRange& r) {
  if (auto why = unknown_key(j, where, {"continuous", "min_deg", "max_deg", "cable_wrap"});
      !why.empty())
    return why;
  read_value(j, "continuous", r.continuous);
  read_value(j, "min_deg", r.min_deg);
  read_value(j, "max_deg", r.max_deg);
  if (j.contains("cable_wrap")) {
    const auto policy = j.at("cable_wrap").get<std::string>();
    if (policy == "nearest")
      r.cable_wrap = CableWrap::nearest;
    else if (policy == "centred")
      r.cable_wrap = CableWrap::centred;
    else
      return where + ".cable_wrap must be \"nearest\" or \"centred\"";
  }
  if (!r.continuous && !(r.min_deg < r.max_deg)) return where + ": need min_deg < max_deg";
  return {};
}

std::string parse_all(const json& j, ModbusStandConfig& c) {
  if (!j.is_object()) return "the top level must be a JSON object";
  if (auto why = unknown_key(j, "the top level",
                             {"word_order", "angle_lsb_deg", "speed_lsb_dps", "registers", "timing",
                              "axes", "speed_dps", "enable_timeout_s"});
      !why.empty())
    return why;
  if (j.contains("word_order")) {
    const auto order = j.at("word_order").get<std::string>();
    if (order == "high_first")
      c.map.word_order = WordOrder::high_first;
    else if (order == "low_first")
      c.map.word_order = WordOrder::low_first;
    else
      return "word_order must be \"high_first\" or \"low_first\"";
  }
  read_value(j, "angle_lsb_deg", c.map.angle_lsb_deg);
  read_value(j, "speed_lsb_dps", c.map.speed_lsb_dps);
  if (!(c.map.angle_lsb_deg > 0) || !(c.map.speed_lsb_dps > 0))
    return "angle_lsb_deg and speed_lsb_dps must be > 0";
  read_value(j, "speed_dps", c.speed_dps);
  read_value(j, "enable_timeout_s", c.enable_timeout_s);
  if (j.contains("registers")) {
    if (auto why = parse_registers(j.at("registers"), c.map); !why.empty()) return why;
  }
  if (j.contains("timing")) {
    if (auto why = parse_timing(j.at("timing"), c.timing); !why.empty()) return why;
  }
  if (j.contains("axes")) {
    const json& axes = j.at("axes");
    if (auto why = unknown_key(axes, "axes", {"outer", "inner"}); !why.empty()) return why;
    if (axes.contains("outer")) {
      if (auto why = parse_range(axes.at("outer"), "axes.outer", c.ranges[0]); !why.empty())
        return why;
    }
    if (axes.contains("inner")) {
      if (auto why = parse_range(axes.at("inner"), "axes.inner", c.ranges[1]); !why.empty())
        return why;
    }
  }
  return {};
}

int max_address(std::initializer_list<int> addresses) { return std::max(addresses); }

}  // namespace

int RegisterMap::holding_size() const {
  int top = max_address({heartbeat, heartbeat_timeout_ms, global_command});
  for (const auto& a : axes)
    top = std::max({top, a.target + 1, static_cast<int>(a.speed), static_cast<int>(a.command)});
  return top + 1;
}

int RegisterMap::input_size() const {
  int top = max_address({global_flags, map_version});
  for (const auto& a : axes)
    top = std::max({top, static_cast<int>(a.state), static_cast<int>(a.flags), a.angle + 1,
                    static_cast<int>(a.fault), static_cast<int>(a.command_count)});
  return top + 1;
}

const char* fault_text(int code) {
  switch (code) {
    case 0:
      return "no fault";
    case kFaultFollowing:
      return "following error: the axis does not follow the command (stuck or blocked)";
    case kFaultSoftLimit:
      return "soft limit reached";
    case kFaultDrive:
      return "drive fault";
    case kFaultHoming:
      return "homing failed: reference not found";
    default:
      return "unknown fault code (see the controller's manual)";
  }
}

void put_i32(std::uint16_t* regs, std::int32_t value, WordOrder order) {
  const auto bits = static_cast<std::uint32_t>(value);
  const auto high = static_cast<std::uint16_t>(bits >> 16);
  const auto low = static_cast<std::uint16_t>(bits & 0xFFFFu);
  regs[0] = order == WordOrder::high_first ? high : low;
  regs[1] = order == WordOrder::high_first ? low : high;
}

std::int32_t get_i32(const std::uint16_t* regs, WordOrder order) {
  const std::uint32_t high = order == WordOrder::high_first ? regs[0] : regs[1];
  const std::uint32_t low = order == WordOrder::high_first ? regs[1] : regs[0];
  return static_cast<std::int32_t>((high << 16) | low);
}

Result<std::int32_t> angle_to_counts(const RegisterMap& map, double angle_deg) {
  const double counts = std::round(angle_deg / map.angle_lsb_deg);
  if (!std::isfinite(counts) || counts > std::numeric_limits<std::int32_t>::max() ||
      counts < std::numeric_limits<std::int32_t>::min())
    return Status::error(
        ErrorKind::invalid_argument,
        "angle " + std::to_string(angle_deg) + "° does not fit the 32-bit angle register");
  return static_cast<std::int32_t>(counts);
}

double counts_to_angle_deg(const RegisterMap& map, std::int32_t counts) {
  return counts * map.angle_lsb_deg;
}

double heartbeat_held_s(const LinkTiming& t) {
  return t.heartbeat_period_s + t.tries * t.timeout_s;
}

std::string heartbeat_margin_warning(const LinkTiming& t) {
  if (t.heartbeat_timeout_s <= 0) return "";  // the watchdog is off
  const double held_s = heartbeat_held_s(t);
  if (held_s <= t.heartbeat_timeout_s + 1e-9) return "";  // equal, but for rounding: no margin lost
  char text[512];
  std::snprintf(
      text, sizeof text,
      "timing: a request retried %d times at timeout_s %g s, after a heartbeat_period_s "
      "of %g s, holds the heartbeat for up to %g s, longer than heartbeat_timeout_s %g s: "
      "lost replies then stop the axes (the controller's watchdog) before the driver "
      "calls the link lost; give heartbeat_timeout_s %g s or more, or fewer tries or a "
      "shorter timeout_s",
      t.tries, t.timeout_s, t.heartbeat_period_s, held_s, t.heartbeat_timeout_s, held_s);
  return text;
}

std::string watchdog_off_warning(const LinkTiming& t) {
  if (t.heartbeat_timeout_s > 0) return "";
  return "timing: heartbeat_timeout_s 0 switches the controller's heartbeat watchdog off: a "
         "service that dies or loses the link mid-move leaves the stand moving to its target "
         "(give heartbeat_timeout_s, e.g. 1 s)";
}

std::vector<std::string> unattended_warnings(const ModbusStandConfig& config,
                                             const std::string& path) {
  std::vector<std::string> out = config.warnings;  // load_config named the file in these
  if (auto off = watchdog_off_warning(config.timing); !off.empty())
    out.push_back((path.empty() ? "" : path + ": ") + off);
  return out;
}

Result<ModbusStandConfig> parse_config(const nlohmann::json& json) {
  ModbusStandConfig config;
  try {
    if (auto why = parse_all(json, config); !why.empty()) return config_error(why);
  } catch (const nlohmann::json::exception& e) {
    return config_error(e.what());
  }
  if (auto warning = heartbeat_margin_warning(config.timing); !warning.empty())
    config.warnings.push_back(std::move(warning));
  return config;
}

Result<ModbusStandConfig> load_config(const std::string& path) {
  if (path.empty()) return ModbusStandConfig{};
  std::ifstream in(path);
  if (!in) return config_error("cannot open " + path);
  nlohmann::json json;
  try {
    in >> json;
  } catch (const nlohmann::json::exception& e) {
    return config_error(path + ": " + e.what());
  }
  auto config = parse_config(json);
  if (!config) return config_error(path + ": " + config.status().message.substr(14));
  for (std::string& warning : config.value().warnings) warning = path + ": " + warning;
  return config;
}

}  // namespace standcal::drivers::modbus
