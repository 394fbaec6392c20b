#pragma once
// Number checks for CLI11 options that say what is wanted. CLI11's own PositiveNumber and
// NonNegativeNumber report a bad value as "not in range 0.000000 to 17976931348623157...",
// the largest double written out in 309 digits.
#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>

#include "calib/text.hpp"

namespace standcal::cli_checks {

// A bound as an operator reads it: a whole number in full (1000000, not 1e+06), else
// CLI11's shortest form (1e-12).
inline std::string bound_text(double bound) {
  if (std::abs(bound) < 1e15 && bound == static_cast<double>(static_cast<long long>(bound)))
    return std::to_string(static_cast<long long>(bound));
  return CLI::detail::to_string(bound);
}

// A number above `lower` (or at least it, `inclusive`) and, where given, at most `upper`;
// the message says which ("must be > 0 and <= 1000000 (got 2e6)").
inline CLI::Validator number_within(double lower, bool inclusive,
                                    std::optional<double> upper = std::nullopt) {
  std::string wanted = std::string(inclusive ? ">= " : "> ") + bound_text(lower);
  if (upper) wanted += " and <= " + bound_text(*upper);
  return CLI::Validator(
      [lower, inclusive, upper, wanted](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value)) return "'" + text + "' is not a number";
        const bool above = inclusive ? value >= lower : value > lower;
        const bool ok = above && (!upper || value <= *upper);
        return ok ? std::string() : "must be " + wanted + " (got " + text + ")";
      },
      "NUMBER " + wanted);
}

inline CLI::Validator lower_bound(double bound, bool inclusive) {
  return number_within(bound, inclusive);
}

inline CLI::Validator positive_at_most(double upper) { return number_within(0, false, upper); }

// Text the records database keeps, refused before any work where it is not UTF-8 (a name
// typed in Latin-1): the database would refuse it only after the fit.
inline const CLI::Validator kUtf8Text(
    [](std::string& text) -> std::string {
      const auto at = first_non_utf8_byte(text);
      return at ? "must be UTF-8 text: byte " + std::to_string(*at + 1) + " is not" : "";
    },
    "");  // no word in --help: the option's own type already says TEXT

// A file whose full path the records database keeps (import stores it absolute): a working
// directory whose name is not UTF-8 is refused before any work, as such a file name is
// (by kUtf8Text, which alone speaks of a name that is not UTF-8 itself).
inline const CLI::Validator kUtf8FullPath(
    [](std::string& path) -> std::string {
      if (first_non_utf8_byte(path)) return "";
      std::error_code error;
      const std::string full = std::filesystem::absolute(path, error).string();
      if (error) return "its full path is unknown: " + error.message();
      const auto at = first_non_utf8_byte(full);
      return at ? "its full path, which the records keep, must be UTF-8 text: byte " +
                      std::to_string(*at + 1) + " is not"
                : "";
    },
    "");

inline const CLI::Validator kPositive = lower_bound(0, false);
inline const CLI::Validator kNonNegative = lower_bound(0, true);

}  // namespace standcal::cli_checks
