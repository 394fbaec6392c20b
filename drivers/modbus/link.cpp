// ModbusLink: retries, exceptions and re-opening with back-off over libmodbus.
#include "drivers/modbus/link.hpp"

#include <modbus.h>

#include <cerrno>
#include <cstdio>
#include <thread>

namespace standcal::drivers::modbus {

namespace {

using Clock = std::chrono::steady_clock;

void set_timeout(modbus_t* ctx, double seconds) {
  const auto whole = static_cast<std::uint32_t>(seconds);
  const auto micro = static_cast<std::uint32_t>((seconds - whole) * 1e6);
  modbus_set_response_timeout(ctx, whole, micro);
  modbus_set_byte_timeout(ctx, whole, micro);
}

// Errors after which the same connection can be used again (after a flush).
bool recoverable_on_same_connection(int error_number) {
  return error_number == ETIMEDOUT || error_number == EMBBADCRC || error_number == EMBBADDATA ||
         error_number == EMBMDATA || error_number == EMBBADSLAVE || error_number == EMBBADEXC ||
         error_number == EMBUNKEXC;
}

}  // namespace

std::string exception_text(int error_number) {
  const int code = error_number - MODBUS_ENOBASE;
  if (code < MODBUS_EXCEPTION_ILLEGAL_FUNCTION || code > MODBUS_EXCEPTION_GATEWAY_TARGET) return {};
  static const char* const kMeaning[] = {
      "",
      "illegal function",
      "illegal data address",
      "illegal data value",
      "server device failure",
      "acknowledge",
      "server device busy",
      "negative acknowledge",
      "memory parity error",
      "not defined",
      "gateway path unavailable",
      "gateway target device failed to respond",
  };
  return "modbus exception " + std::to_string(code) + " (" + kMeaning[code] + ")";
}

ModbusLink::ModbusLink(ModbusUrl url, LinkTiming timing)
    : url_(std::move(url)), timing_(timing), name_(describe(url_)) {}

ModbusLink::~ModbusLink() { close(); }

Status ModbusLink::open() {
  close();
  const bool tcp = url_.transport == ModbusUrl::Transport::tcp;
  modbus_t* ctx = tcp ? modbus_new_tcp_pi(url_.host.c_str(), std::to_string(url_.port).c_str())
                      : modbus_new_rtu(url_.device.c_str(), url_.baud, url_.parity, url_.data_bits,
                                       url_.stop_bits);
  if (ctx == nullptr)
    return Status::error(ErrorKind::link, "cannot create a Modbus context for " + name_ + ": " +
                                              modbus_strerror(errno));
  modbus_set_slave(ctx, url_.unit);
  set_timeout(ctx, timing_.timeout_s);
  if (modbus_connect(ctx) == -1) {
    const int e = errno;
    modbus_free(ctx);
    return Status::error(ErrorKind::link, "cannot connect to " + name_ + ": " + modbus_strerror(e));
  }
  if (!tcp && url_.rs485 && modbus_rtu_set_serial_mode(ctx, MODBUS_RTU_RS485) == -1) {
    const int e = errno;
    modbus_close(ctx);
    modbus_free(ctx);
    return Status::error(ErrorKind::link,
                         "cannot switch " + url_.device + " to RS-485 mode: " + modbus_strerror(e));
  }
  ctx_ = ctx;
  ++opens_;
  backoff_s_ = 0.0;
  return Status::ok();
}

void ModbusLink::close() {
  if (ctx_ == nullptr) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

Status ModbusLink::open_with_retries() {
  close();
  next_open_ = Clock::now();
  std::string reason;
  for (int attempt = 1; attempt <= timing_.tries; ++attempt) {
    auto opened = reopen_after_backoff();
    if (opened) return opened;
    reason = opened.message;
  }
  return Status::error(ErrorKind::link,
                       "no reply from " + name_ + " after " + std::to_string(timing_.tries) +
                           (timing_.tries == 1 ? " try" : " tries") + " (" + reason + ")");
}

Status ModbusLink::reopen_if_due() {
  if (ctx_ != nullptr) return Status::ok();
  if (Clock::now() < next_open_)
    return Status::error(ErrorKind::link, "link to " + name_ + " is down (back-off)");
  return reopen_after_backoff();
}

// Waits out the back-off, then opens; a failed open doubles the back-off.
Status ModbusLink::reopen_after_backoff() {
  std::this_thread::sleep_until(next_open_);
  auto opened = open();
  if (!opened) {
    backoff_s_ = backoff_s_ == 0.0 ? timing_.backoff_first_s
                                   : std::min(2 * backoff_s_, timing_.backoff_max_s);
    next_open_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(backoff_s_));
  }
  return opened;
}

template <class Op>
Status ModbusLink::call(const std::string& what, Op op) {
  std::string last_reason;
  ErrorKind last_kind = ErrorKind::timeout;
  for (int attempt = 1; attempt <= timing_.tries; ++attempt) {
    if (ctx_ == nullptr) {
      if (auto opened = reopen_after_backoff(); !opened) {
        last_reason = opened.message;
        last_kind = ErrorKind::link;
        continue;
      }
    }
    errno = 0;
    if (op(ctx_) != -1) return Status::ok();
    const int e = errno;
    if (auto exception = exception_text(e); !exception.empty())
      return Status::error(ErrorKind::protocol, exception + " from " + name_ + " while " + what);
    last_reason = modbus_strerror(e);
    last_kind = ErrorKind::timeout;
    if (e == EMBBADDATA && url_.transport == ModbusUrl::Transport::tcp) {
      // Most often the reply to an earlier try that came after its timeout. More may still
      // be on the way, which a flush now would miss and every later try would read: only
      // a new connection is sure to carry none of them.
      close();
      next_open_ = Clock::now();
    } else if (recoverable_on_same_connection(e)) {
      modbus_flush(ctx_);  // a late reply must not answer the next request
    } else {
      close();  // reset, broken pipe: the next attempt re-opens at once
      next_open_ = Clock::now();
    }
  }
  // Bounded retries are used up: drop the link; the next request re-opens it after a back-off.
  if (ctx_ != nullptr) {
    close();
    backoff_s_ = timing_.backoff_first_s;
    next_open_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(backoff_s_));
  }
  return Status::error(last_kind, "no reply from " + name_ + " after " +
                                      std::to_string(timing_.tries) +
                                      (timing_.tries == 1 ? " try" : " tries") + " (" + what +
                                      ": " + last_reason + ")");
}

Status ModbusLink::read_input(std::uint16_t address, int count, std::uint16_t* dest,
                              const std::string& what) {
  return call(
      what, [&](modbus_t* ctx) { return modbus_read_input_registers(ctx, address, count, dest); });
}

Status ModbusLink::read_holding(std::uint16_t address, int count, std::uint16_t* dest,
                                const std::string& what) {
  return call(what,
              [&](modbus_t* ctx) { return modbus_read_registers(ctx, address, count, dest); });
}

Status ModbusLink::write(std::uint16_t address, int count, const std::uint16_t* values,
                         const std::string& what) {
  return call(what, [&](modbus_t* ctx) {
    return count == 1 ? modbus_write_register(ctx, address, values[0])
                      : modbus_write_registers(ctx, address, count, values);
  });
}

}  // namespace standcal::drivers::modbus
