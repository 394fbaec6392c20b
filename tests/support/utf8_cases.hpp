#pragma once
// Byte strings and where each stops being well-formed UTF-8 (the Unicode standard's table
// 3-7), for the two rooms' checks: calib/text.hpp's (the file formats) and
// protocol/jsonrpc/text.hpp's (the operator protocol). Both are utfcpp's, and must agree with
// the standard here: each was a hand-written decoder until 2026-12-05.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace standcal::test {

struct Utf8Case {
  std::string bytes;
  std::optional<std::size_t> first_bad_byte;  // 0-based; nullopt: all of it is UTF-8
  const char* what;
};

inline std::vector<Utf8Case> utf8_cases() {
  return {
      {"", std::nullopt, "empty"},
      {"AU-0042", std::nullopt, "ASCII"},
      {"M\xC3\xBC"
       "ller",
       std::nullopt, "U+00FC"},
      {"\xE0\xA0\x80", std::nullopt, "U+0800, the lowest three-byte character"},
      {"\xED\x9F\xBF", std::nullopt, "U+D7FF, below the surrogates"},
      {"\xEE\x80\x80", std::nullopt, "U+E000, above the surrogates"},
      {"\xF0\x90\x80\x80", std::nullopt, "U+10000, the lowest four-byte character"},
      {"\xF4\x8F\xBF\xBF", std::nullopt, "U+10FFFF, the highest"},
      {"a\x80", 1, "a stray continuation byte"},
      {"M\xFC"
       "ller",
       1, "Latin-1"},
      {"\xC0\xAF", 0, "overlong two bytes"},
      {"\xC1\xBF", 0, "overlong two bytes (C1)"},
      {"\xE0\x9F\xBF", 0, "overlong three bytes"},
      {"\xED\xA0\x80", 0, "a surrogate"},
      {"\xF0\x8F\xBF\xBF", 0, "overlong four bytes"},
      {"\xF4\x90\x80\x80", 0, "past U+10FFFF"},
      {"\xF5\x80\x80\x80", 0, "a lead byte past U+10FFFF"},
      {"\xFF", 0, "FF"},
      {"ab\xE2\x82\x41", 2, "a bad third byte"},
      {"\xF0\x9F\x94\x41", 0, "a bad fourth byte"},
      {"x\xC3", 1, "cut short after its lead byte"},
      {"\xE2\x82", 0, "cut short after two of three"},
  };
}

}  // namespace standcal::test
