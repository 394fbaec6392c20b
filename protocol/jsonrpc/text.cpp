#include "protocol/jsonrpc/text.hpp"

#include <cstdio>

#include <utf8.h>

#include "protocol/jsonrpc/jsonrpc.hpp"

namespace standcal::protocol {

namespace {

std::string code_point_name(char32_t cp) {
  char name[16];
  std::snprintf(name, sizeof name, "U+%04X", static_cast<unsigned>(cp));
  return name;
}

const char* unprintable_kind(char32_t cp) {
  if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) return "the control character ";
  if (cp == 0x2028 || cp == 0x2029) return "the line separator ";
  return nullptr;
}

// utfcpp's check: a stray continuation byte, a cut-short, overlong or surrogate sequence and
// a code point past U+10FFFF are not UTF-8.
std::string_view::const_iterator first_invalid(std::string_view text) {
  return utf8::find_invalid(text.begin(), text.end());
}

}  // namespace

std::optional<std::string> text_field_problem(std::string_view text, std::size_t max_chars) {
  // The characters before the first byte that is not UTF-8, in order: a control character
  // there is the first problem, the byte the next.
  const auto invalid = first_invalid(text);
  std::size_t chars = 0;
  for (auto it = text.begin(); it != invalid;) {
    const auto cp = static_cast<char32_t>(utf8::unchecked::next(it));
    ++chars;
    if (const char* kind = unprintable_kind(cp)) {
      return "be printable text on one line: it contains " + std::string(kind) +
             code_point_name(cp) + " at character " + std::to_string(chars);
    }
  }
  if (invalid != text.end())
    return "be UTF-8 text: byte " + std::to_string(invalid - text.begin() + 1) + " is not";
  if (chars > max_chars) {
    return "be at most " + std::to_string(max_chars) + " characters (UTF-8 code points), not " +
           std::to_string(chars);
  }
  return std::nullopt;
}

std::optional<std::size_t> first_non_utf8_byte(std::string_view text) {
  const auto invalid = first_invalid(text);
  if (invalid == text.end()) return std::nullopt;
  return static_cast<std::size_t>(invalid - text.begin());
}

void require_text_field(const std::string& what, std::string_view text, std::size_t max_chars) {
  if (const auto problem = text_field_problem(text, max_chars)) {
    throw RpcError(ErrorCode::invalid_params, what + " must " + *problem);
  }
}

}  // namespace standcal::protocol
