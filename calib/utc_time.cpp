#include "calib/utc_time.hpp"

#include <chrono>

namespace standcal {

namespace {

class Cursor {
 public:
  explicit Cursor(std::string_view s) : s_(s) {}
  // `count` digits, or -1 (and nothing consumed) when they are not there.
  int digits(int count) {
    int v = 0;
    for (int i = 0; i < count; ++i) {
      if (pos_ + i >= s_.size() || s_[pos_ + i] < '0' || s_[pos_ + i] > '9') return -1;
      v = v * 10 + (s_[pos_ + i] - '0');
    }
    pos_ += count;
    return v;
  }
  bool take(std::string_view any_of) {
    if (pos_ < s_.size() && any_of.find(s_[pos_]) != std::string_view::npos) {
      ++pos_;
      return true;
    }
    return false;
  }
  void skip_digits() {
    while (pos_ < s_.size() && s_[pos_] >= '0' && s_[pos_] <= '9') ++pos_;
  }
  bool at_end() const { return pos_ == s_.size(); }
  char previous() const { return s_[pos_ - 1]; }

 private:
  std::string_view s_;
  std::size_t pos_ = 0;
};

// "2026-11-21" or "20261121": days since the epoch, or empty.
std::optional<std::int64_t> date_days(Cursor& c) {
  const int y = c.digits(4);
  const bool extended = c.take("-");
  const int mo = c.digits(2);
  if (extended && !c.take("-")) return std::nullopt;
  const int d = c.digits(2);
  if (y < 0 || mo < 0 || d < 0) return std::nullopt;
  using namespace std::chrono;
  const year_month_day ymd{year{y}, month{static_cast<unsigned>(mo)},
                           day{static_cast<unsigned>(d)}};
  if (!ymd.ok()) return std::nullopt;
  return sys_days{ymd}.time_since_epoch().count();
}

// "22:15", "22:15:00", "22:15:00.75", "221500": seconds into the day, or empty.
std::optional<std::int64_t> time_of_day_s(Cursor& c) {
  const int h = c.digits(2);
  const bool extended = c.take(":");
  const int mi = c.digits(2);
  int s = 0;
  const bool seconds_follow = extended ? c.take(":") : true;  // "2215": basic, no seconds
  if (seconds_follow) {
    const int read = c.digits(2);
    if (read >= 0)
      s = read;
    else if (extended)
      return std::nullopt;  // "22:15:" with nothing after
  }
  if (c.take(".,")) c.skip_digits();  // whole seconds kept
  if (h < 0 || h > 23 || mi < 0 || mi > 59 || s > 60) return std::nullopt;
  return h * 3600L + mi * 60L + s;
}

// Seconds east of UTC from "Z", "+02:00", "-0130"; `absent` when nothing is left.
std::optional<std::int64_t> zone_offset_s(Cursor& c, std::optional<std::int64_t> absent) {
  while (c.take(" ")) {
  }
  if (c.at_end()) return absent;
  if (c.take("Zz")) return 0;
  if (!c.take("+-")) return std::nullopt;
  const std::int64_t sign = c.previous() == '-' ? -1 : 1;
  const int hh = c.digits(2);
  c.take(":");
  const int mm = c.digits(2);
  if (hh < 0 || hh > 23 || mm < 0 || mm > 59) return std::nullopt;
  return sign * (hh * 3600L + mm * 60L);
}

}  // namespace

std::optional<std::int64_t> parse_utc_s(std::string_view text, UtcParseRules rules) {
  Cursor c(text);
  const auto days = date_days(c);
  if (!days) return std::nullopt;
  std::optional<std::int64_t> seconds = rules.end_of_day ? 86399 : 0;
  if (c.take("T ")) seconds = time_of_day_s(c);
  if (!seconds) return std::nullopt;
  const auto offset =
      zone_offset_s(c, rules.require_zone ? std::nullopt : std::optional<std::int64_t>(0));
  if (!offset || !c.at_end()) return std::nullopt;
  return *days * 86400 + *seconds - *offset;
}

}  // namespace standcal
