#include "protocol/jsonrpc/text.hpp"

#include <cstdio>

#include "protocol/jsonrpc/jsonrpc.hpp"

namespace standcal::protocol {

namespace {

struct Utf8Form {
  std::size_t length;
  unsigned char payload_mask;
  char32_t smallest;  // below it the form is overlong
};

// The form a lead byte starts, or nothing for a byte that cannot start a character.
std::optional<Utf8Form> form_of(unsigned char lead) {
  if (lead < 0x80) return Utf8Form{1, 0x7F, 0};
  if ((lead & 0xE0) == 0xC0) return Utf8Form{2, 0x1F, 0x80};
  if ((lead & 0xF0) == 0xE0) return Utf8Form{3, 0x0F, 0x800};
  if ((lead & 0xF8) == 0xF0) return Utf8Form{4, 0x07, 0x10000};
  return std::nullopt;
}

// The code point at text[i] (i advanced past it), or nothing when the bytes there are not
// UTF-8: a stray continuation byte, a cut-short, overlong or surrogate sequence, past U+10FFFF.
std::optional<char32_t> next_code_point(std::string_view text, std::size_t& i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const auto form = form_of(byte(i));
  if (!form || i + form->length > text.size()) return std::nullopt;
  char32_t cp = byte(i) & form->payload_mask;
  for (std::size_t k = 1; k < form->length; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return std::nullopt;
    cp = (cp << 6) | (byte(i + k) & 0x3F);
  }
  if (cp < form->smallest || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return std::nullopt;
  i += form->length;
  return cp;
}

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

}  // namespace

std::optional<std::string> text_field_problem(std::string_view text, std::size_t max_chars) {
  std::size_t chars = 0;
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t at_byte = i;
    const auto cp = next_code_point(text, i);
    ++chars;
    if (!cp) return "be UTF-8 text: byte " + std::to_string(at_byte + 1) + " is not";
    if (const char* kind = unprintable_kind(*cp)) {
      return "be printable text on one line: it contains " + std::string(kind) +
             code_point_name(*cp) + " at character " + std::to_string(chars);
    }
  }
  if (chars > max_chars) {
    return "be at most " + std::to_string(max_chars) + " characters (UTF-8 code points), not " +
           std::to_string(chars);
  }
  return std::nullopt;
}

std::optional<std::size_t> first_non_utf8_byte(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t at = i;
    if (!next_code_point(text, i)) return at;
  }
  return std::nullopt;
}

void require_text_field(const std::string& what, std::string_view text, std::size_t max_chars) {
  if (const auto problem = text_field_problem(text, max_chars)) {
    throw RpcError(ErrorCode::invalid_params, what + " must " + *problem);
  }
}

}  // namespace standcal::protocol
