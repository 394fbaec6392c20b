#pragma once
// One libmodbus connection with bounded retries and re-opening with back-off. Not
// thread-safe, like the libmodbus context it owns: only the ModbusStand's I/O thread
// uses it. Transport differences (TCP, RTU) are confined to open().
#include <chrono>
#include <cstdint>
#include <string>

#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/url.hpp"
#include "drivers/status.hpp"

struct _modbus;  // libmodbus's modbus_t

namespace standcal::drivers::modbus {

class ModbusLink {
 public:
  ModbusLink(ModbusUrl url, LinkTiming timing);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  Status open();               // opens now (ignoring back-off); closes a previous context first
  Status open_with_retries();  // up to timing.tries opens with back-off between them
  void close();                // closes; the next request re-opens after the back-off
  Status reopen_if_due();      // one open without waiting, if closed and the back-off has passed
  bool is_open() const { return ctx_ != nullptr; }
  // Requests, each tried up to timing.tries times; `what` names the request in messages.
  Status read_input(std::uint16_t address, int count, std::uint16_t* dest, const std::string& what);
  Status read_holding(std::uint16_t address, int count, std::uint16_t* dest,
                      const std::string& what);
  Status write(std::uint16_t address, int count, const std::uint16_t* values,
               const std::string& what);
  int opens() const { return opens_; }  // successful opens so far (first one included)
  const std::string& name() const { return name_; }

 private:
  template <class Op>
  Status call(const std::string& what, Op op);
  Status reopen_after_backoff();

  ModbusUrl url_;
  LinkTiming timing_;
  std::string name_;
  _modbus* ctx_ = nullptr;
  int opens_ = 0;
  double backoff_s_ = 0.0;
  std::chrono::steady_clock::time_point next_open_{};
};

// "modbus exception 2 (illegal data address)" for errno values from libmodbus; empty
// when errno is not a Modbus exception.
std::string exception_text(int error_number);

}  // namespace standcal::drivers::modbus
