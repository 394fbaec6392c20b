// The CAN frame-layout reader (drivers/socketcan/frame_layout.hpp FrameLayout::from_json,
// docs/unit-can.md). It returns a Result, so no exception may escape. Properties: an
// accepted layout holds the start bit and length the file gave (nothing wrapped into an
// int), and encodes a sample into frames that decode back to the same counter with all
// three forces present.
#include <nlohmann/json.hpp>
#include <string>

#include "drivers/socketcan/frame_layout.hpp"
#include "fuzz/targets/can_layout_checks.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace can = standcal::drivers::can;

namespace {

// Numbers of signal i in the file must be the numbers the layout uses.
void check_numbers_kept(const nlohmann::json& doc, const can::FrameLayout& layout) {
  const auto& given = doc["signals"];
  const auto& kept = layout.signals();
  if (given.size() != kept.size()) return;  // the layout's signal list is not the file's
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const auto check = [&](const char* key, int value) {
      if (!given[i].is_object() || !given[i].contains(key) || !given[i][key].is_number()) return;
      standcal::fuzz::require(given[i][key].get<double>() == value,
                              "can_layout_json: signals[" + std::to_string(i) + "]." + key +
                                  " given as " + given[i][key].dump() + " was accepted as " +
                                  std::to_string(value));
    };
    check("start_bit", kept[i].start_bit);
    check("length", kept[i].length);
  }
}

}  // namespace

int standcal_fuzz_can_layout_json(const std::uint8_t* data, std::size_t size) {
  const auto doc = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: from_file rejects it before from_json
  return standcal::fuzz::expect_no_exceptions("can_layout_json", [&] {
    const auto layout = can::FrameLayout::from_json(doc);
    if (!layout) return;
    check_numbers_kept(doc, layout.value());
    standcal::fuzz::check_layout_round_trip(layout.value(), "can_layout_json");
  });
}
