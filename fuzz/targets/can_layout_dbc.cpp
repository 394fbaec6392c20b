// The DBC reader for the unit's CAN layout (drivers/socketcan/dbc.hpp layout_from_dbc,
// docs/unit-can.md). It returns a Result, so no exception may escape. Properties: every
// signal parse_dbc reports lies on a line of the input and has a length of 1..64 bits; an
// accepted layout encodes a sample into frames that decode back to it.
#include <algorithm>
#include <string>
#include <string_view>

#include "drivers/socketcan/dbc.hpp"
#include "fuzz/targets/can_layout_checks.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace can = standcal::drivers::can;

int standcal_fuzz_can_layout_dbc(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  return standcal::fuzz::expect_no_exceptions("can_layout_dbc", [&] {
    const auto parsed = can::parse_dbc(text, "fuzz.dbc");
    if (parsed) {
      const auto lines = static_cast<int>(std::count(text.begin(), text.end(), '\n')) + 1;
      for (const auto& s : parsed.value()) {
        standcal::fuzz::require(s.line >= 1 && s.line <= lines,
                                "can_layout_dbc: signal " + s.spec.name + " on line " +
                                    std::to_string(s.line) + " of " + std::to_string(lines));
        standcal::fuzz::require(s.spec.length >= 1 && s.spec.length <= 64,
                                "can_layout_dbc: signal " + s.spec.name + " has length " +
                                    std::to_string(s.spec.length));
      }
    }
    const auto layout = can::layout_from_dbc(text, "fuzz.dbc");
    if (layout) standcal::fuzz::check_layout_round_trip(layout.value(), "can_layout_dbc");
  });
}
