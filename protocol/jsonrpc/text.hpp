#pragma once
// Operator text fields (unit serial, unit type, operator, programme name, run ids): one
// line of printable UTF-8 text, its length counted in characters (UTF-8 code points),
// because they end up in line-based files (the recording header), in the records
// database and in front of people (reports, certificates).
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace standcal::protocol {

// Why `text` is not one line of printable text of at most `max_chars` characters, as the
// rest of a sentence after "must " ("be printable text on one line: it contains the
// control character U+000A at character 3"), or empty when it is. Refused: bytes that are not
// UTF-8, control characters (C0 U+0000–U+001F, DEL, C1 U+0080–U+009F), the line and paragraph
// separators U+2028/U+2029.
std::optional<std::string> text_field_problem(std::string_view text, std::size_t max_chars);

// The 0-based offset of the first byte of `text` that is not part of a UTF-8 character, or
// nothing when all of it is UTF-8: utfcpp's check, as calib/text.hpp's for the file formats
// (this room depends on nlohmann-json and utfcpp alone).
std::optional<std::size_t> first_non_utf8_byte(std::string_view text);

// Throws RpcError(invalid_params) "WHAT must be …" when text_field_problem finds one;
// `what` names the method and the field ("run.start: parameter \"unit_serial\"").
void require_text_field(const std::string& what, std::string_view text, std::size_t max_chars);

}  // namespace standcal::protocol
