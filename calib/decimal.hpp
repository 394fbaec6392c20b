#pragma once
// Decimal numbers as recordings write them ("-9.816196357", "14.0100"), parsed without
// std::from_chars's general machinery: with at most 15 significant digits the mantissa and
// the power of ten are exact doubles, so one division gives the correctly rounded value
// (Clinger's fast path) -- the same double std::from_chars returns. Anything else
// (exponents, longer mantissas, text) is left to the caller's general parser.
#include <array>
#include <cstdint>
#include <string_view>

namespace standcal {

// Reads [-]digits[.digits] with 1..15 digits in all from `p` on, stopping at the first
// byte that cannot continue it (`p` is left there: a reader scanning a row checks that the
// field ends there). False, with `p` and `out` unspecified, when there is no such number.
inline bool scan_plain_decimal(const char*& p, const char* const end, double& out) {
  static constexpr std::array<double, 16> kPowersOfTen{
      1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  const bool negative = p != end && *p == '-';
  if (negative) ++p;
  // Digit by digit: taking eight at a time (fast_float's SWAR trick) measured no faster
  // here, the numbers being short (docs/performance.md).
  std::uint64_t mantissa = 0;
  int digits = 0;
  int fraction_digits = 0;
  for (; p != end && static_cast<unsigned>(*p - '0') < 10; ++p, ++digits)
    mantissa = mantissa * 10 + static_cast<unsigned>(*p - '0');
  if (p != end && *p == '.') {
    for (++p; p != end && static_cast<unsigned>(*p - '0') < 10; ++p, ++digits, ++fraction_digits)
      mantissa = mantissa * 10 + static_cast<unsigned>(*p - '0');
  }
  // With at most 15 digits the mantissa is exact (< 2^53). Longer ones may have wrapped
  // (unsigned, so defined) and are refused here.
  if (digits == 0 || digits > 15) return false;
  const double value =
      static_cast<double>(mantissa) / kPowersOfTen[static_cast<std::size_t>(fraction_digits)];
  out = negative ? -value : value;
  return true;
}

// True and `out` set when `text` is [-]digits[.digits] with 1..15 digits in all.
inline bool parse_plain_decimal(std::string_view text, double& out) {
  const char* p = text.data();
  const char* const end = p + text.size();
  double value = 0;
  if (!scan_plain_decimal(p, end, value) || p != end) return false;
  out = value;
  return true;
}

}  // namespace standcal
