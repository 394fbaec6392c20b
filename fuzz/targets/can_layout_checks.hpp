#pragma once
// The property every accepted CAN layout must have, whichever file it came from (JSON or
// DBC): a sample it encodes decodes back to the same counter with all three forces.
#include <cstdint>
#include <string>

#include "drivers/socketcan/frame_layout.hpp"
#include "fuzz/targets/fuzz_support.hpp"

namespace standcal::fuzz {

inline void check_layout_round_trip(const drivers::can::FrameLayout& layout,
                                    const std::string& target) {
  const std::uint64_t counter = 5 % layout.counter_modulus();
  const auto frames = layout.encode({0.1, -0.2, 9.8}, 23.5, counter);
  std::uint8_t forces_seen = 0;
  for (const auto& f : frames) {
    drivers::can::FrameValues values;
    require(layout.decode(f.can_id, f.data.data(), f.len, values),
            target + ": a frame the layout encoded does not decode");
    forces_seen |= values.force_mask;
    if (values.has_counter)
      require(values.counter == counter, target + ": counter " + std::to_string(counter) +
                                             " decoded as " + std::to_string(values.counter));
  }
  require(forces_seen == 0b111, target + ": an encoded sample lacks a force axis");
}

}  // namespace standcal::fuzz
