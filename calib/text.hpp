#pragma once
// One-line text fields of the file formats (recording header values, programme names):
// they must hold no control character, because a newline would start a new header line
// ("# mount: y" injected through a unit serial) and a NUL ends C strings early.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace standcal {

// A control character found in a text: C0 (U+0000–U+001F), DEL (U+007F) or C1
// (U+0080–U+009F, as UTF-8), with its 1-based position counted in characters (UTF-8
// code points).
struct ControlCharacter {
  char32_t code_point = 0;
  std::size_t character = 0;
};
std::optional<ControlCharacter> find_control_character(std::string_view text);

// "the control character U+000A at character 3", for error messages.
std::string describe(const ControlCharacter& c);

// The 0-based offset of the first byte where `text` stops being well-formed UTF-8 (a
// stray continuation byte, a Latin-1 letter, a cut-short, overlong or surrogate sequence,
// past U+10FFFF), or nothing when all of it is. Text other programs must read as text
// (JSON, PostgreSQL, a browser) has to be UTF-8; replacing a byte would change a serial.
std::optional<std::size_t> first_non_utf8_byte(std::string_view text);

// A number as an operator writes it, six significant digits: 122.5, not 122.500000;
// 7.36e+161.
std::string number_text(double v);
// "x,y,z" as its fields, empty ones kept ("a,,b": "a", "", "b"): the lists an option or a
// configuration key takes as one text (--columns, unit.static_recording_input.columns).
std::vector<std::string> split_at_commas(const std::string& text);
// The axes `chosen` flags (x, y, z in order; any beyond three ignored), as a sentence names
// them: "x", "x and z", "x, y and z"; "" for none.
std::string axis_names(const std::vector<bool>& chosen);
// One value per axis, each as `printf_format` writes it, then `unit` (none where empty):
// "1.10 / 6.40 / 11.90 ug (x/y/z)", as every report and log spells per-axis figures.
std::string axes_text(const char* printf_format, double x, double y, double z,
                      std::string_view unit = "");
// A value found past its limit and the limit, as number_text writes them, with more digits
// (the same for both) where six would show them equal in size: "5000.004 µg above the
// limit 5000 µg", not "5000 µg above the limit 5000 µg".
struct NumberTextsApart {
  std::string value;
  std::string limit;
};
NumberTextsApart number_texts_apart(double value, double limit);
// The same with a fixed number of decimals, at least `decimals` (a certificate's "1.00 µg"):
// "σ 1.004 µg EXCEEDS the allowed 1.000 µg", not "σ 1.00 µg EXCEEDS the allowed 1.00 µg".
// A margin past zero is such a pair too: fixed_texts_apart(0.004, 0, 2).value is "0.004".
NumberTextsApart fixed_texts_apart(double value, double limit, int decimals);
// The decimals fixed_texts_apart writes both at.
int fixed_decimals_apart(double value, double limit, int decimals);
// The shortest text that reads back as exactly `v` (100, 0.5, 1e-07): for a value a file
// must keep, where std::to_string's six decimals write 1e-07 as 0.000000.
std::string round_trip_text(double v);
// The same in plain decimals from 0.0001 to below 1e15 (100000 and 0.0005, where
// round_trip_text writes 1e+05 and 5e-04): for a number an operator reads beside a bound.
std::string plain_round_trip_text(double v);

}  // namespace standcal
