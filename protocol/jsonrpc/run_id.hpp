#pragma once
// The form of a run id (docs/daemon.md): UTC-STAMP-SERIAL, e.g. 20261121T223638Z-AU-0042,
// with an optional -002 … suffix. The serial part holds only [A-Za-z0-9._-] (the daemon
// replaces anything else), so a run id is always one plain path component under
// STATE/runs: checking the form is what keeps a run id from a user from naming a path
// outside the state directory ("../../elsewhere/x").
#include <cctype>
#include <string_view>

namespace standcal::protocol {

inline bool is_run_id(std::string_view id) {
  constexpr std::string_view stamp = "########T######Z-";  // '#': a digit
  if (id.size() <= stamp.size()) return false;
  for (std::size_t i = 0; i < stamp.size(); ++i) {
    const bool digit = std::isdigit(static_cast<unsigned char>(id[i])) != 0;
    if (stamp[i] == '#' ? !digit : id[i] != stamp[i]) return false;
  }
  for (const char ch : id.substr(stamp.size())) {
    const bool plain =
        std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '_' || ch == '-';
    if (!plain) return false;
  }
  return true;
}

}  // namespace standcal::protocol
