#pragma once
// Test fixture: a socketpair(AF_UNIX, SOCK_SEQPACKET) standing in for a CAN bus (this
// kernel has no CAN). One end goes to the driver; on the other the test writes real
// `struct can_frame` / `struct canfd_frame` bytes, exactly as a raw CAN socket reads them.
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <thread>

#include "drivers/socketcan/frame_layout.hpp"

namespace standcal::drivers::can::testing {

class CanPair {
 public:
  CanPair() {
    int fds[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0)
      throw std::runtime_error("socketpair failed");
    unit_fd_ = fds[0];
    bus_fd_ = fds[1];
  }
  ~CanPair() {
    if (bus_fd_ >= 0) close(bus_fd_);
    if (unit_fd_ >= 0) close(unit_fd_);
  }
  CanPair(const CanPair&) = delete;
  CanPair& operator=(const CanPair&) = delete;

  // Hands the driver's end over (the driver closes it).
  int release_unit_fd() { return std::exchange(unit_fd_, -1); }
  int bus_fd() const { return bus_fd_; }
  void close_bus() { close(std::exchange(bus_fd_, -1)); }

  // Writes one classic frame: 16 bytes of struct can_frame.
  void send_classic(std::uint32_t can_id, const std::uint8_t* data, std::uint8_t len) const {
    can_frame f{};
    f.can_id = can_id;
    f.len = len;
    std::memcpy(f.data, data, len);
    if (write(bus_fd_, &f, sizeof f) != static_cast<ssize_t>(sizeof f))
      throw std::runtime_error("write can_frame failed");
  }
  // Writes one CAN FD frame: 72 bytes of struct canfd_frame.
  void send_fd(std::uint32_t can_id, const std::uint8_t* data, std::uint8_t len) const {
    canfd_frame f{};
    f.can_id = can_id;
    f.len = len;
    std::memcpy(f.data, data, len);
    if (write(bus_fd_, &f, sizeof f) != static_cast<ssize_t>(sizeof f))
      throw std::runtime_error("write canfd_frame failed");
  }
  // Writes an error frame as the kernel reports controller trouble.
  void send_error(std::uint32_t err_class, std::uint8_t ctrl_bits = 0) const {
    std::uint8_t d[CAN_ERR_DLC] = {};
    d[1] = ctrl_bits;
    send_classic(CAN_ERR_FLAG | err_class, d, CAN_ERR_DLC);
  }
  // Writes one encoded frame of a layout (classic when it fits in 8 bytes).
  void send(const EncodedFrame& e) const {
    if (e.len <= 8)
      send_classic(e.can_id, e.data.data(), e.len);
    else
      send_fd(e.can_id, e.data.data(), e.len);
  }

 private:
  int unit_fd_ = -1;
  int bus_fd_ = -1;
};

// Runs `writer` on a thread after `delay_s`, so its frames arrive while the caller is
// inside collect(); joins it on destruction.
class DelayedWriter {
 public:
  DelayedWriter(double delay_s, std::function<void()> writer)
      : thread_([delay_s, w = std::move(writer)] {
          std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
          w();
        }) {}
  ~DelayedWriter() { thread_.join(); }
  DelayedWriter(const DelayedWriter&) = delete;
  DelayedWriter& operator=(const DelayedWriter&) = delete;

 private:
  std::thread thread_;
};

}  // namespace standcal::drivers::can::testing
