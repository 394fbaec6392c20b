// Parsing of the emulator's fault lines (see faults.hpp).
#include "tools/stand-emu/faults.hpp"

#include <sstream>

namespace standcal::emu {

namespace {

bool axis_index(const std::string& name, int& index) {
  if (name == "outer" || name == "1")
    index = 0;
  else if (name == "inner" || name == "2")
    index = 1;
  else
    return false;
  return true;
}

bool parse_line(const std::string& line, Faults& f) {
  std::istringstream in(line);
  std::string word;
  if (!(in >> word) || word[0] == '#') return true;
  std::string axis_name;
  int axis = 0;
  if (word == "stuck" || word == "drive_fault") {
    if (!(in >> axis_name) || !axis_index(axis_name, axis)) return false;
    (word == "stuck" ? f.stuck : f.drive_fault)[static_cast<std::size_t>(axis)] = true;
  } else if (word == "slow") {
    double factor = 0;
    if (!(in >> axis_name >> factor) || !axis_index(axis_name, axis) || factor < 1.0) return false;
    f.slow[static_cast<std::size_t>(axis)] = factor;
  } else if (word == "overshoot") {
    double deg = 0;
    if (!(in >> axis_name >> deg) || !axis_index(axis_name, axis) || !(deg >= 0.0 && deg <= 4.0))
      return false;
    f.overshoot_deg[static_cast<std::size_t>(axis)] = deg;
  } else if (word == "delay_ms") {
    if (!(in >> f.delay_ms) || f.delay_ms < 0) return false;
    if (!(in >> f.delay_count)) {
      f.delay_count = -1;  // no count: every reply
    } else if (f.delay_count < 1) {
      return false;
    }
  } else if (word == "exception") {
    if (!(in >> f.exception_code) || f.exception_code < 1 || f.exception_code > 11) return false;
    if (!(in >> f.exception_count)) f.exception_count = -1;
  } else if (word == "drop" || word == "corrupt") {
    int count = 1;
    if (in >> count && count < 1) return false;
    (word == "drop" ? f.drop_count : f.corrupt_count) = count;
  } else {
    return false;
  }
  return true;
}

}  // namespace

bool parse_faults(const std::vector<std::string>& lines, Faults& out, std::string& error) {
  Faults faults;
  for (const auto& line : lines) {
    if (!parse_line(line, faults)) {
      error = "bad fault line '" + line + "' (see standcal-stand-emu --help)";
      return false;
    }
  }
  out = faults;
  return true;
}

}  // namespace standcal::emu
