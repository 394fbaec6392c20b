#pragma once
// UTC timestamps in the one form standcal writes everywhere (run.json, results, the
// records database, certificates): ISO 8601 to the second, "2026-11-22T07:13:50Z"; and the
// one parser that reads them back, and the forms people and other tools type.
#include <cstdint>
#include <ctime>
#include <optional>
#include <string>
#include <string_view>

namespace standcal {

inline std::string utc_iso(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

inline std::string utc_now_iso() { return utc_iso(std::time(nullptr)); }

struct UtcParseRules {
  // A date without a time is its last second (a "until" filter) rather than its first.
  bool end_of_day = false;
  // The text must say it is UTC or give its offset ("Z", "+02:00"); without it a time
  // without a zone is taken as UTC.
  bool require_zone = false;
};

// Seconds since 1970-01-01T00:00:00Z of a date or time: "2026-11-21", "2026-11-21T22:15",
// "2026-11-21 22:15:00.75", "2026-11-21T22:15:00Z", "2026-01-01T01:30:00+02:00", "-0130",
// and run ids' compact form "20261121T223638Z". Fractions of a second are dropped. Empty
// when the text is none of these or names a day that is not in the calendar (2026-02-30).
std::optional<std::int64_t> parse_utc_s(std::string_view text, UtcParseRules rules = {});

}  // namespace standcal
