// The emulated stand controller (see emulator.hpp).
#include "tools/stand-emu/emulator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace standcal::emu {

namespace {

using drivers::modbus::AxisRegisters;
using drivers::modbus::GlobalCommand;
using drivers::modbus::ModbusUrl;

std::uint16_t word_at(const std::uint8_t* bytes) {
  return static_cast<std::uint16_t>((bytes[0] << 8) | bytes[1]);
}

std::runtime_error failure(const std::string& what) {
  return std::runtime_error(what + ": " + modbus_strerror(errno));
}

}  // namespace

Emulator::Emulator(EmulatorOptions options)
    : options_(std::move(options)), faults_(options_.faults) {
  for (int i = 0; i < 2; ++i)
    sims_.emplace_back(options_.axes[static_cast<std::size_t>(i)],
                       options_.start_deg[static_cast<std::size_t>(i)],
                       options_.seed + static_cast<unsigned>(i));
}

Emulator::~Emulator() {
  for (int fd : clients_) close(fd);
  if (server_fd_ >= 0) close(server_fd_);
  if (ctx_ != nullptr) {
    modbus_close(ctx_);
    modbus_free(ctx_);
  }
  if (mapping_ != nullptr) modbus_mapping_free(mapping_);
}

std::string Emulator::open() {
  const ModbusUrl& url = options_.listen;
  const auto& map = options_.map;
  mapping_ = modbus_mapping_new(0, 0, map.holding_size(), map.input_size());
  if (mapping_ == nullptr) throw failure("cannot allocate the register tables");
  mapping_->tab_registers[map.heartbeat_timeout_ms] =
      static_cast<std::uint16_t>(options_.heartbeat_timeout_ms);
  mapping_->tab_input_registers[map.map_version] = drivers::modbus::kMapVersion;
  if (url.transport == ModbusUrl::Transport::tcp) {
    ctx_ = modbus_new_tcp(url.host.c_str(), url.port);
    if (ctx_ == nullptr) throw failure("cannot create a TCP server for " + url.text);
    server_fd_ = modbus_tcp_listen(ctx_, 8);
    if (server_fd_ == -1) throw failure("cannot listen on " + url.text);
    sockaddr_in address{};
    socklen_t length = sizeof address;
    getsockname(server_fd_, reinterpret_cast<sockaddr*>(&address), &length);
    const auto now = Clock::now();
    last_step_ = last_beat_ = next_control_poll_ = now;
    return "tcp://" + url.host + ":" + std::to_string(ntohs(address.sin_port));
  }
  ctx_ = modbus_new_rtu(url.device.c_str(), url.baud, url.parity, url.data_bits, url.stop_bits);
  if (ctx_ == nullptr) throw failure("cannot create an RTU server for " + url.text);
  modbus_set_slave(ctx_, url.unit);
  if (modbus_connect(ctx_) == -1) throw failure("cannot open " + url.device);
  const auto now = Clock::now();
  last_step_ = last_beat_ = next_control_poll_ = now;
  return url.text;
}

void Emulator::run(const volatile std::sig_atomic_t& stop_requested) {
  const bool tcp = options_.listen.transport == ModbusUrl::Transport::tcp;
  while (!stop_requested) {
    poll_control_file();
    advance();
    write_status_file();
    fd_set readable;
    FD_ZERO(&readable);
    int top = -1;
    const auto watch = [&](int fd) {
      FD_SET(fd, &readable);
      top = std::max(top, fd);
    };
    if (tcp) {
      watch(server_fd_);
      for (int fd : clients_) watch(fd);
    } else {
      watch(modbus_get_socket(ctx_));
    }
    timeval tick{0, 2000};  // the simulation advances at least every 2 ms
    const int ready = select(top + 1, &readable, nullptr, nullptr, &tick);
    // After serving what arrived, so a heartbeat waiting in the socket still counts.
    if (ready <= 0) {
      watch_heartbeat();
      continue;
    }
    if (tcp && FD_ISSET(server_fd_, &readable)) {
      const int client = modbus_tcp_accept(ctx_, &server_fd_);
      if (client >= 0) clients_.push_back(client);
    }
    if (!tcp) {
      serve_one(modbus_get_socket(ctx_));
      watch_heartbeat();
      continue;
    }
    for (auto it = clients_.begin(); it != clients_.end();) {
      if (FD_ISSET(*it, &readable) && !serve_one(*it)) {
        close(*it);
        it = clients_.erase(it);
      } else {
        ++it;
      }
    }
    watch_heartbeat();
  }
}

void Emulator::advance() {
  const auto now = Clock::now();
  const double dt_s = std::chrono::duration<double>(now - last_step_).count() * options_.time_scale;
  last_step_ = now;
  for (std::size_t i = 0; i < 2; ++i) {
    sims_[i].set_stuck(faults_.stuck[i]);
    sims_[i].set_slow(faults_.slow[i]);
    sims_[i].set_overshoot(faults_.overshoot_deg[i]);
    if (faults_.drive_fault[i]) {
      sims_[i].inject_drive_fault();
      faults_.drive_fault[i] = false;
    }
    sims_[i].step(dt_s);
  }
}

// Comm-loss safety: no change of the heartbeat register for longer than its timeout stops
// every motion in a controlled way; the axes stay enabled and not faulted.
void Emulator::watch_heartbeat() {
  const auto now = Clock::now();
  const std::uint16_t beat = mapping_->tab_registers[options_.map.heartbeat];
  if (beat != last_heartbeat_) {
    last_heartbeat_ = beat;
    last_beat_ = now;
    heartbeat_lost_ = false;
  }
  const int timeout_ms = mapping_->tab_registers[options_.map.heartbeat_timeout_ms];
  if (timeout_ms == 0 || heartbeat_lost_ ||
      now - last_beat_ <= std::chrono::milliseconds(timeout_ms))
    return;
  heartbeat_lost_ = true;
  bool stopped = false;
  for (auto& s : sims_) stopped = s.stop_for_heartbeat_loss() || stopped;
  if (stopped)
    std::fprintf(stderr, "standcal-stand-emu: no heartbeat for %d ms: motion stopped\n",
                 timeout_ms);
}

void Emulator::publish() {
  const auto& map = options_.map;
  std::uint16_t global = heartbeat_lost_ ? drivers::modbus::kGlobalHeartbeatLost : 0;
  for (int i = 0; i < 2; ++i) {
    const AxisRegisters& r = map.axes[static_cast<std::size_t>(i)];
    std::uint16_t* in = mapping_->tab_input_registers;
    in[r.state] = static_cast<std::uint16_t>(sim(i).state());
    in[r.flags] = sim(i).flags();
    const auto counts = drivers::modbus::angle_to_counts(map, sim(i).reading_deg());
    drivers::modbus::put_i32(&in[r.angle], counts ? counts.value() : 0, map.word_order);
    in[r.fault] = sim(i).fault_code();
    in[r.command_count] = sim(i).command_count();
    if (sim(i).flags() & drivers::modbus::kFlagEstop) global |= drivers::modbus::kGlobalEstop;
  }
  mapping_->tab_input_registers[map.global_flags] = global;
}

void Emulator::poll_control_file() {
  if (options_.control_file.empty() || Clock::now() < next_control_poll_) return;
  next_control_poll_ = Clock::now() + std::chrono::milliseconds(50);
  std::ifstream in(options_.control_file);
  if (!in) return;
  std::stringstream text;
  text << in.rdbuf();
  if (text.str() == control_text_) return;
  control_text_ = text.str();
  std::vector<std::string> lines;
  for (std::string line; std::getline(text, line);) lines.push_back(line);
  std::string error;
  if (!parse_faults(lines, faults_, error))
    std::fprintf(stderr, "standcal-stand-emu: %s\n", error.c_str());
}

// What a test asks the controller without being a Modbus master itself (an RTU line has
// room for one): per axis a line "NAME STATE FLAGS ANGLE_COUNTS FAULT" from the input
// registers, replaced atomically.
void Emulator::write_status_file() {
  if (options_.status_file.empty() || Clock::now() < next_status_write_) return;
  next_status_write_ = Clock::now() + std::chrono::milliseconds(50);
  publish();
  const auto& map = options_.map;
  std::ostringstream text;
  for (int i = 0; i < 2; ++i) {
    const AxisRegisters& r = map.axes[static_cast<std::size_t>(i)];
    const std::uint16_t* in = mapping_->tab_input_registers;
    text << (i == 0 ? "outer" : "inner") << ' ' << in[r.state] << ' ' << in[r.flags] << ' '
         << drivers::modbus::get_i32(&in[r.angle], map.word_order) << ' ' << in[r.fault] << '\n';
  }
  const std::string tmp = options_.status_file + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text.str();
    if (!out) return;
  }
  std::rename(tmp.c_str(), options_.status_file.c_str());
}

bool Emulator::serve_one(int fd) {
  const bool tcp = options_.listen.transport == ModbusUrl::Transport::tcp;
  modbus_set_socket(ctx_, fd);
  std::uint8_t query[MODBUS_MAX_ADU_LENGTH];
  const int length = modbus_receive(ctx_, query);
  if (length == 0) return true;  // addressed to another unit
  if (length < 0) {
    if (!tcp) modbus_flush(ctx_);  // a damaged frame on the line: wait for the next
    return !tcp;
  }
  if (faults_.drop_count > 0) {
    --faults_.drop_count;
    return !tcp;  // TCP: the connection closes; RTU: this request gets no reply
  }
  if (faults_.delay_ms > 0 && faults_.delay_count != 0) {
    if (faults_.delay_count > 0) --faults_.delay_count;
    std::this_thread::sleep_for(std::chrono::milliseconds(faults_.delay_ms));
  }
  if (faults_.exception_count != 0) {
    if (faults_.exception_count > 0) --faults_.exception_count;
    modbus_reply_exception(ctx_, query, static_cast<unsigned>(faults_.exception_code));
    return true;
  }
  advance();  // the reply shows the state as of now, also after a delay
  publish();
  if (const int code = refusal_exception(query, length); code != 0) {
    modbus_reply_exception(ctx_, query, static_cast<unsigned>(code));
    return true;
  }
  if (faults_.corrupt_count > 0) {
    --faults_.corrupt_count;
    send_corrupted(query, length);
    modbus_set_socket(ctx_, fd);
  } else {
    modbus_reply(ctx_, query, length, mapping_);
  }
  act_on_commands();
  return true;
}

// A command the axis cannot execute is refused before the write lands: exception 4
// (server device failure) when it cannot act now, 3 (illegal data value) for a bad value.
int Emulator::refusal_exception(const std::uint8_t* query, int length) {
  const int header = modbus_get_header_length(ctx_);
  const int function = query[header];
  std::vector<std::uint16_t> holding(mapping_->tab_registers,
                                     mapping_->tab_registers + mapping_->nb_registers);
  std::vector<int> written;
  const auto write = [&](int address, std::uint16_t value) {
    if (address >= 0 && address < mapping_->nb_registers) {
      holding[static_cast<std::size_t>(address)] = value;
      written.push_back(address);
    }
  };
  if (function == MODBUS_FC_WRITE_SINGLE_REGISTER && length >= header + 5) {
    write(word_at(query + header + 1), word_at(query + header + 3));
  } else if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS && length >= header + 6) {
    const int first = word_at(query + header + 1);
    const int count = word_at(query + header + 3);
    for (int i = 0; i < count && header + 6 + 2 * i + 1 < length; ++i)
      write(first + i, word_at(query + header + 6 + 2 * i));
  } else {
    return 0;
  }
  const auto was_written = [&](int address) {
    return std::find(written.begin(), written.end(), address) != written.end();
  };
  const auto& map = options_.map;
  if (was_written(map.global_command) &&
      holding[map.global_command] > static_cast<std::uint16_t>(GlobalCommand::reset))
    return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
  const int timeout_ms = holding[map.heartbeat_timeout_ms];
  const bool heartbeat_stale = timeout_ms > 0 && !was_written(map.heartbeat) &&
                               Clock::now() - last_beat_ > std::chrono::milliseconds(timeout_ms);
  for (int i = 0; i < 2; ++i) {
    const AxisRegisters& r = map.axes[static_cast<std::size_t>(i)];
    if (!was_written(r.command)) continue;
    const std::uint16_t command = holding[r.command];
    if (command > static_cast<std::uint16_t>(AxisCommand::stop))
      return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
    const auto axis_command = static_cast<AxisCommand>(command);
    const bool motion = axis_command == AxisCommand::move || axis_command == AxisCommand::home;
    if (motion && heartbeat_stale) return MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE;
    const double target_deg = drivers::modbus::counts_to_angle_deg(
        map, drivers::modbus::get_i32(&holding[r.target], map.word_order));
    switch (sim(i).check(axis_command, target_deg)) {
      case Refusal::none:
        break;
      case Refusal::cannot_now:
        return MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE;
      case Refusal::bad_value:
        return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
    }
  }
  return 0;
}

void Emulator::act_on_commands() {
  const auto& map = options_.map;
  std::uint16_t* holding = mapping_->tab_registers;
  for (int i = 0; i < 2; ++i) {
    const AxisRegisters& r = map.axes[static_cast<std::size_t>(i)];
    if (holding[r.command] == 0) continue;
    const double target_deg = drivers::modbus::counts_to_angle_deg(
        map, drivers::modbus::get_i32(&holding[r.target], map.word_order));
    sim(i).command(static_cast<AxisCommand>(holding[r.command]), target_deg,
                   holding[r.speed] * map.speed_lsb_dps);
    holding[r.command] = 0;  // acted on
  }
  const auto global = static_cast<GlobalCommand>(holding[map.global_command]);
  if (global == GlobalCommand::emergency_stop)
    for (auto& s : sims_) s.emergency_stop();
  if (global == GlobalCommand::reset)
    for (auto& s : sims_) s.reset();
  holding[map.global_command] = 0;
  publish();
}

// Lets libmodbus build the correct reply into a socket pair, damages one byte in the
// middle (so an RTU CRC no longer matches) and sends that instead.
void Emulator::send_corrupted(const std::uint8_t* query, int length) {
  const int client = modbus_get_socket(ctx_);
  int pair[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, pair) != 0) return;
  modbus_set_socket(ctx_, pair[0]);
  modbus_reply(ctx_, query, length, mapping_);
  std::uint8_t reply[MODBUS_MAX_ADU_LENGTH + 8];
  const ssize_t size = read(pair[1], reply, sizeof reply);
  close(pair[0]);
  close(pair[1]);
  if (size <= 0) return;
  reply[size / 2] ^= 0x5A;
  if (write(client, reply, static_cast<std::size_t>(size)) != size)
    std::fprintf(stderr, "standcal-stand-emu: short write of a corrupted reply\n");
}

}  // namespace standcal::emu
