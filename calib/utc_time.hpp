#pragma once
// UTC timestamps in the one form standcal writes everywhere (run.json, results, the
// records database, certificates): ISO 8601 to the second, "2026-11-22T07:13:50Z".
#include <ctime>
#include <string>

namespace standcal {

inline std::string utc_iso(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

inline std::string utc_now_iso() { return utc_iso(std::time(nullptr)); }

}  // namespace standcal
