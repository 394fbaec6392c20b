#include "calib/text.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>

#include <utf8.h>

namespace standcal {

namespace {

bool is_continuation_byte(unsigned char b) { return (b & 0xC0) == 0x80; }

}  // namespace

std::optional<ControlCharacter> find_control_character(std::string_view text) {
  std::size_t character = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto b = static_cast<unsigned char>(text[i]);
    if (!is_continuation_byte(b)) ++character;
    if (b < 0x20 || b == 0x7F) return ControlCharacter{b, character};
    // U+0080–U+009F are encoded as C2 80 – C2 9F.
    if (b == 0xC2 && i + 1 < text.size()) {
      const auto next = static_cast<unsigned char>(text[i + 1]);
      if (next >= 0x80 && next <= 0x9F) return ControlCharacter{next, character};
    }
  }
  return std::nullopt;
}

std::string describe(const ControlCharacter& c) {
  char code[16];
  std::snprintf(code, sizeof code, "U+%04X", static_cast<unsigned>(c.code_point));
  return std::string("the control character ") + code + " at character " +
         std::to_string(c.character);
}

std::optional<std::size_t> first_non_utf8_byte(std::string_view text) {
  // utfcpp's check: overlong forms, surrogates and code points past U+10FFFF are not UTF-8.
  const auto invalid = utf8::find_invalid(text.begin(), text.end());
  if (invalid == text.end()) return std::nullopt;
  return static_cast<std::size_t>(invalid - text.begin());
}

std::string round_trip_text(double v) {
  std::array<char, 32> buf{};  // the longest shortest double: 24 characters
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return ec == std::errc() ? std::string(buf.data(), end) : number_text(v);
}

std::string plain_round_trip_text(double v) {
  if (!(v == 0 || (std::abs(v) >= 1e-4 && std::abs(v) < 1e15))) return round_trip_text(v);
  std::array<char, 48> buf{};  // 15 digits before the point, 17 significant after 0.000
  const auto [end, ec] =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed);
  return ec == std::errc() ? std::string(buf.data(), end) : round_trip_text(v);
}

namespace {

std::string significant_digits_text(double v, int digits) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string fixed_decimals_text(double v, int decimals) {
  char buf[360];  // 1e308 in full, and its decimals
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The least precision from `precision` up to `most` that shows the two apart in size. A value
// equal to its limit, or alike even at `most`, stays at `precision`: more digits would only
// show the binary fraction of both (0.10000000000000001) or a row of zeros.
template <typename Format>
int precision_apart(double value, double limit, int precision, int most, Format text) {
  if (std::abs(value) == std::abs(limit)) return precision;
  for (int p = precision; p <= most; ++p)
    if (text(std::abs(value), p) != text(std::abs(limit), p)) return p;
  return precision;
}

}  // namespace

std::string number_text(double v) { return significant_digits_text(v, 6); }

std::string axes_text(const char* printf_format, double x, double y, double z,
                      std::string_view unit) {
  std::string out;
  for (const double v : {x, y, z}) {
    char buf[64];
    std::snprintf(buf, sizeof buf, printf_format, v);
    out += (out.empty() ? "" : " / ") + std::string(buf);
  }
  return out + (unit.empty() ? "" : " " + std::string(unit)) + " (x/y/z)";
}

NumberTextsApart number_texts_apart(double value, double limit) {
  // 17 significant digits tell any two doubles apart.
  const int digits = precision_apart(value, limit, 6, 17, significant_digits_text);
  return {significant_digits_text(value, digits), significant_digits_text(limit, digits)};
}

int fixed_decimals_apart(double value, double limit, int decimals) {
  // Past 20 decimals a difference is of no certificate's concern (and 40 fit the buffer).
  return precision_apart(value, limit, decimals, std::clamp(decimals, 20, 40), fixed_decimals_text);
}

NumberTextsApart fixed_texts_apart(double value, double limit, int decimals) {
  const int apart = fixed_decimals_apart(value, limit, decimals);
  return {fixed_decimals_text(value, apart), fixed_decimals_text(limit, apart)};
}

std::vector<std::string> split_at_commas(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    out.push_back(
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

std::string axis_names(const std::vector<bool>& chosen) {
  std::vector<char> axes;
  for (std::size_t a = 0; a < chosen.size() && a < 3; ++a)
    if (chosen[a]) axes.push_back("xyz"[a]);
  std::string names;
  for (std::size_t k = 0; k < axes.size(); ++k)
    names += std::string(k == 0 ? "" : k + 1 == axes.size() ? " and " : ", ") + axes[k];
  return names;
}

}  // namespace standcal
