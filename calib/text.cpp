#include "calib/text.hpp"

#include <array>
#include <charconv>
#include <cstdio>

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

std::string round_trip_text(double v) {
  std::array<char, 32> buf{};  // the longest shortest double: 24 characters
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return ec == std::errc() ? std::string(buf.data(), end) : number_text(v);
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace standcal
