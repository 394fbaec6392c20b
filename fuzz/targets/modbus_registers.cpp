// The stand's reply decoding (drivers/modbus/register_map.hpp): the register words of a
// status reply turned into angles, fault texts and Modbus exception texts.
//
// The request/response framing itself is libmodbus's (modbus_read_input_registers in
// ModbusLink, drivers/modbus/link.cpp), and the state-code check sits in ModbusStand's
// private read path, reachable only through a live link: this target covers the pure
// decoding the driver applies to the words libmodbus hands it.
//
// Input: byte 0 picks the word order (bit 0) and the angle LSB (bits 1..2) among
// documented-style values; the rest are 16-bit register words, taken in pairs.
// Properties: put_i32 inverts get_i32 in either word order; a 32-bit count read from the
// controller converts to an angle that converts back to the same count.
#include <modbus/modbus.h>

#include <cstring>
#include <string>

#include "drivers/modbus/link.hpp"
#include "drivers/modbus/register_map.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace modbus = standcal::drivers::modbus;

namespace {

void check_pair(const modbus::RegisterMap& map, const std::uint16_t words[2]) {
  const std::int32_t counts = modbus::get_i32(words, map.word_order);
  std::uint16_t again[2] = {0, 0};
  modbus::put_i32(again, counts, map.word_order);
  standcal::fuzz::require(again[0] == words[0] && again[1] == words[1],
                          "modbus_registers: put_i32(get_i32(w)) != w");
  const double angle_deg = modbus::counts_to_angle_deg(map, counts);
  const auto back = modbus::angle_to_counts(map, angle_deg);
  standcal::fuzz::require(static_cast<bool>(back),
                          "modbus_registers: angle " + std::to_string(angle_deg) +
                              " read from the controller cannot be commanded back");
  standcal::fuzz::require(back.value() == counts,
                          "modbus_registers: counts " + std::to_string(counts) +
                              " -> angle -> counts gave " + std::to_string(back.value()));
}

}  // namespace

int standcal_fuzz_modbus_registers(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  return standcal::fuzz::expect_no_exceptions("modbus_registers", [&] {
    static constexpr double kLsbs_deg[] = {0.0001, 0.001, 0.00001, 0.01};
    modbus::RegisterMap map;
    map.word_order = (data[0] & 1) ? modbus::WordOrder::low_first : modbus::WordOrder::high_first;
    map.angle_lsb_deg = kLsbs_deg[(data[0] >> 1) & 3];
    for (std::size_t i = 1; i + 4 <= size; i += 4) {
      std::uint16_t words[2];
      std::memcpy(words, data + i, sizeof words);
      check_pair(map, words);
      // The fault-code register is a raw word too.
      standcal::fuzz::require(modbus::fault_text(words[0]) != nullptr,
                              "modbus_registers: fault_text gave null");
      // An exception reply reaches the driver as an errno value: a system errno, or
      // libmodbus's MODBUS_ENOBASE + the exception code the controller sent (one byte).
      const int error_number =
          (words[1] & 1) ? MODBUS_ENOBASE + (words[0] & 0xFF) : words[0] & 0xFFF;
      (void)modbus::exception_text(error_number);
    }
  });
}
