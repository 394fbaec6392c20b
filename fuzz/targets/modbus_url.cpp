// The stand URL parser (drivers/modbus/url.hpp): arbitrary text as a --stand URL. It
// returns a Result, so no exception may escape. Property: an accepted URL has values in
// the documented ranges (port 0..65535, unit 0..247, parity N/E/O).
#include <string>

#include "drivers/modbus/url.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace modbus = standcal::drivers::modbus;

int standcal_fuzz_modbus_url(const std::uint8_t* data, std::size_t size) {
  const std::string text(standcal::fuzz::as_text(data, size));
  return standcal::fuzz::expect_no_exceptions("modbus_url", [&] {
    const auto url = modbus::parse_url(text);
    if (!url) return;
    const modbus::ModbusUrl& u = url.value();
    standcal::fuzz::require(u.port >= 0 && u.port <= 65535,
                            "modbus_url: accepted port " + std::to_string(u.port));
    standcal::fuzz::require(u.unit >= 0 && u.unit <= 247,
                            "modbus_url: accepted unit " + std::to_string(u.unit));
    if (u.transport == modbus::ModbusUrl::Transport::rtu)
      standcal::fuzz::require(u.parity == 'N' || u.parity == 'E' || u.parity == 'O',
                              std::string("modbus_url: accepted parity '") + u.parity + "'");
    (void)modbus::describe(u);
  });
}
