#pragma once
// The config tests' question: what does parse_config say is wrong with this document?
#include <nlohmann/json.hpp>
#include <string>

#include "daemon/standcald/config.hpp"

namespace standcal::test {

// The ConfigError message for `doc` read as "lab.json", or "" when it parses.
inline std::string config_error(const nlohmann::json& doc) {
  try {
    daemon::parse_config(doc, "lab.json");
  } catch (const daemon::ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace standcal::test
