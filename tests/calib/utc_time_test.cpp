// The one UTC parser (calib/utc_time.hpp): the forms it reads, and what it refuses.
#include "calib/utc_time.hpp"

#include <gtest/gtest.h>

namespace standcal {
namespace {

constexpr std::int64_t kDay_s = 86400;
// 2026-11-21T00:00:00Z, from an independent source: `date -u -d 2026-11-21 +%s`.
constexpr std::int64_t kNov21_s = 1795219200;

TEST(UtcTime, EveryFormStandcalAndItsUsersWrite) {
  EXPECT_EQ(parse_utc_s("2026-11-21"), kNov21_s);
  EXPECT_EQ(parse_utc_s("2026-11-21", {.end_of_day = true}), kNov21_s + kDay_s - 1);
  EXPECT_EQ(parse_utc_s("2026-11-21T22:15:07Z"), kNov21_s + 22 * 3600 + 15 * 60 + 7);
  EXPECT_EQ(parse_utc_s("2026-11-21 22:15"), kNov21_s + 22 * 3600 + 15 * 60);
  EXPECT_EQ(parse_utc_s("2026-11-21T22:15:07.999Z"), kNov21_s + 22 * 3600 + 15 * 60 + 7);
  EXPECT_EQ(parse_utc_s("20261121T221507Z"), parse_utc_s("2026-11-21T22:15:07Z"));
  EXPECT_EQ(parse_utc_s("2026-11-21T01:30:00+02:00"), kNov21_s - 30 * 60);
  EXPECT_EQ(parse_utc_s("2026-11-21T01:30:00-0130"), kNov21_s + 3 * 3600);
  EXPECT_EQ(parse_utc_s(utc_iso(static_cast<std::time_t>(kNov21_s + 12345))), kNov21_s + 12345);
}

TEST(UtcTime, WhatIsNotADateOrTimeIsRefused) {
  for (const char* bad :
       {"", "yesterday", "21.11.2026", "2026-13-01", "2026-02-30", "2026-02-29",
        "2026-11-21T24:00:00Z", "2026-11-21T22:60Z", "2026-11-21T22:15:", "2026-11-21T22:15:00Q",
        "2026-11-21T22:15:00+25:00", "2026-11-21T22:15:00Z trailing"})
    EXPECT_FALSE(parse_utc_s(bad).has_value()) << bad;
  EXPECT_TRUE(parse_utc_s("2028-02-29").has_value());  // a leap day
  // A zone required: a time without one is not taken as UTC then.
  EXPECT_FALSE(parse_utc_s("2026-11-21T22:15:07", {.require_zone = true}).has_value());
  EXPECT_TRUE(parse_utc_s("2026-11-21T22:15:07Z", {.require_zone = true}).has_value());
}

}  // namespace
}  // namespace standcal
