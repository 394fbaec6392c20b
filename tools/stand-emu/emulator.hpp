#pragma once
// The emulated stand controller: a libmodbus server serving the documented register map
// (docs/stand-modbus.md) over TCP or RTU, driving two AxisSim, with the heartbeat
// watchdog and injectable faults. Single-threaded: one loop serves requests, advances
// the simulation and polls the control file.
#include <modbus.h>

#include <array>
#include <chrono>
#include <csignal>
#include <string>
#include <vector>

#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/url.hpp"
#include "tools/stand-emu/axis_sim.hpp"
#include "tools/stand-emu/faults.hpp"

namespace standcal::emu {

struct EmulatorOptions {
  drivers::modbus::ModbusUrl listen;
  drivers::modbus::RegisterMap map;
  std::array<AxisModel, 2> axes;
  std::array<double, 2> start_deg{12.5, -33.0};
  double time_scale = 1.0;          // simulated seconds per wall-clock second
  int heartbeat_timeout_ms = 1000;  // initial value of the watchdog register
  Faults faults;
  std::string control_file;  // re-read when it changes; empty: none
  std::string status_file;   // the axes' registers, rewritten every 50 ms; empty: none
  unsigned seed = 1;
};

class Emulator {
 public:
  explicit Emulator(EmulatorOptions options);
  ~Emulator();
  Emulator(const Emulator&) = delete;
  Emulator& operator=(const Emulator&) = delete;

  // Opens the listening socket or serial port; returns the URL clients use (port 0 → the
  // real port), or throws std::runtime_error.
  std::string open();
  // Serves until `stop_requested` becomes true.
  void run(const volatile std::sig_atomic_t& stop_requested);

 private:
  using Clock = std::chrono::steady_clock;
  void advance();
  void watch_heartbeat();
  void publish();
  void poll_control_file();
  void write_status_file();
  bool serve_one(int fd);  // false: close this connection
  int refusal_exception(const std::uint8_t* query, int length);
  void act_on_commands();
  void send_corrupted(const std::uint8_t* query, int length);
  AxisSim& sim(int index) { return sims_[static_cast<std::size_t>(index)]; }

  EmulatorOptions options_;
  std::vector<AxisSim> sims_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int server_fd_ = -1;
  std::vector<int> clients_;
  Faults faults_;
  Clock::time_point last_step_;
  Clock::time_point last_beat_;
  std::uint16_t last_heartbeat_ = 0;
  bool heartbeat_lost_ = false;
  Clock::time_point next_control_poll_;
  Clock::time_point next_status_write_;
  std::string control_text_;
};

}  // namespace standcal::emu
