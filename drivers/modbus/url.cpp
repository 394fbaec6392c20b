// Parsing of the stand URL (tcp://HOST:PORT?unit=1, rtu:/dev/tty...?baud=...).
#include "drivers/modbus/url.hpp"

#include <charconv>
#include <string_view>

namespace standcal::drivers::modbus {

namespace {

Status bad(const std::string& text, const std::string& why) {
  return Status::error(ErrorKind::invalid_argument, "bad stand URL '" + text + "': " + why);
}

bool to_int(std::string_view s, int& out) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc{} && end == s.data() + s.size() && !s.empty();
}

// Applies one key=value of the query; empty on success, else the reason.
std::string apply_option(ModbusUrl& url, std::string_view key, std::string_view value) {
  const bool rtu = url.transport == ModbusUrl::Transport::rtu;
  int number = 0;
  if (key == "unit") {
    if (!to_int(value, number) || number < 0 || number > 247) return "unit must be 0..247";
    url.unit = number;
  } else if (rtu && key == "baud") {
    if (!to_int(value, number) || number <= 0) return "baud must be a positive number";
    url.baud = number;
  } else if (rtu && key == "parity") {
    if (value != "N" && value != "E" && value != "O") return "parity must be N, E or O";
    url.parity = value[0];
  } else if (rtu && key == "data_bits") {
    if (!to_int(value, number) || number < 5 || number > 8) return "data_bits must be 5..8";
    url.data_bits = number;
  } else if (rtu && key == "stop_bits") {
    if (!to_int(value, number) || number < 1 || number > 2) return "stop_bits must be 1 or 2";
    url.stop_bits = number;
  } else if (rtu && key == "rs485") {
    if (value != "0" && value != "1") return "rs485 must be 0 or 1";
    url.rs485 = value == "1";
  } else {
    return "unknown option '" + std::string(key) + "' for " + (rtu ? "rtu" : "tcp");
  }
  return {};
}

std::string apply_query(ModbusUrl& url, std::string_view query) {
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    const auto eq = item.find('=');
    if (eq == std::string_view::npos) return "option '" + std::string(item) + "' has no '='";
    if (auto why = apply_option(url, item.substr(0, eq), item.substr(eq + 1)); !why.empty())
      return why;
  }
  return {};
}

std::string parse_tcp_authority(ModbusUrl& url, std::string_view authority) {
  // [v6]:port is not needed on a lab network; HOST:PORT or HOST.
  const auto colon = authority.rfind(':');
  url.host = std::string(authority.substr(0, colon));
  if (url.host.empty()) return "no host";
  if (colon != std::string_view::npos) {
    int port = 0;
    if (!to_int(authority.substr(colon + 1), port) || port < 0 || port > 65535)
      return "port must be 0..65535";
    url.port = port;
  }
  return {};
}

}  // namespace

Result<ModbusUrl> parse_url(const std::string& text) {
  ModbusUrl url;
  url.text = text;
  std::string_view rest = text;
  const auto question = rest.find('?');
  const std::string_view query =
      question == std::string_view::npos ? std::string_view{} : rest.substr(question + 1);
  rest = rest.substr(0, question);
  std::string why;
  if (rest.starts_with("tcp://")) {
    url.transport = ModbusUrl::Transport::tcp;
    why = parse_tcp_authority(url, rest.substr(6));
  } else if (rest.starts_with("rtu:")) {
    url.transport = ModbusUrl::Transport::rtu;
    url.device = std::string(rest.substr(4));
    if (url.device.starts_with("//")) url.device.erase(0, 2);  // rtu:///dev/x also names /dev/x
    if (url.device.empty() || url.device[0] != '/')
      why = "rtu needs a device path, e.g. rtu:/dev/ttyUSB0";
  } else {
    why =
        "unknown scheme (use tcp://HOST:PORT?unit=1 or "
        "rtu:/dev/ttyUSB0?baud=115200&parity=N&unit=1)";
  }
  if (why.empty()) why = apply_query(url, query);
  if (!why.empty()) return bad(text, why);
  return url;
}

std::string describe(const ModbusUrl& url) {
  const std::string where = url.transport == ModbusUrl::Transport::tcp
                                ? "tcp://" + url.host + ":" + std::to_string(url.port)
                                : "rtu:" + url.device;
  return where + " unit " + std::to_string(url.unit);
}

}  // namespace standcal::drivers::modbus
