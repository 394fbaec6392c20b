#pragma once
// Number checks for CLI11 options that say what is wanted. CLI11's own PositiveNumber and
// NonNegativeNumber report a bad value as "not in range 0.000000 to 17976931348623157...",
// the largest double written out in 309 digits.
#include <CLI/CLI.hpp>
#include <string>

namespace standcal::cli_checks {

inline CLI::Validator lower_bound(double bound, bool inclusive) {
  const std::string wanted = std::string(inclusive ? ">= " : "> ") + CLI::detail::to_string(bound);
  return CLI::Validator(
      [bound, inclusive, wanted](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value)) return "'" + text + "' is not a number";
        const bool ok = inclusive ? value >= bound : value > bound;
        return ok ? std::string() : "must be " + wanted + " (got " + text + ")";
      },
      "NUMBER " + wanted);
}

// A number above 0 and at most `upper` (a whole number, said in full: 1000000, not 1e+06).
inline CLI::Validator positive_at_most(double upper) {
  const std::string wanted = "> 0 and <= " + std::to_string(static_cast<long long>(upper));
  return CLI::Validator(
      [upper, wanted](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value)) return "'" + text + "' is not a number";
        return value > 0 && value <= upper ? std::string()
                                           : "must be " + wanted + " (got " + text + ")";
      },
      "NUMBER " + wanted);
}

inline const CLI::Validator kPositive = lower_bound(0, false);
inline const CLI::Validator kNonNegative = lower_bound(0, true);

}  // namespace standcal::cli_checks
