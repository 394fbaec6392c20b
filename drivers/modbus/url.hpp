#pragma once
// One URL-like string names a stand's link:
//   tcp://HOST:PORT?unit=1
//   rtu:/dev/ttyUSB0?baud=115200&parity=N&unit=1&rs485=1
#include <string>

#include "drivers/status.hpp"

namespace standcal::drivers::modbus {

struct ModbusUrl {
  enum class Transport { tcp, rtu } transport = Transport::tcp;
  std::string host;    // tcp
  int port = 502;      // tcp; 0 only for a listening emulator
  std::string device;  // rtu
  int baud = 19200;    // rtu
  char parity = 'E';   // rtu: N, E or O (Modbus default: even)
  int data_bits = 8;   // rtu
  int stop_bits = 1;   // rtu
  bool rs485 = false;  // rtu: switch the port to RS-485 mode
  int unit = 1;        // Modbus unit (slave) id
  std::string text;    // as given, for messages
};

// Parses a stand URL; errors name the URL and the part that is wrong.
Result<ModbusUrl> parse_url(const std::string& text);
// "tcp://127.0.0.1:1502 unit 1", for operator messages.
std::string describe(const ModbusUrl& url);

}  // namespace standcal::drivers::modbus
