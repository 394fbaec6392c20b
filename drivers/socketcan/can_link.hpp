#pragma once
// Raw CAN transport on a file descriptor: a raw CAN socket bound to an interface, or
// any fd that carries whole `struct can_frame` / `struct canfd_frame` datagrams (a
// socketpair(AF_UNIX, SOCK_SEQPACKET) in tests, an inherited fd from a launcher).
// Non-blocking; receive times are kernel timestamps (SO_TIMESTAMPNS) when available.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/accel_unit.hpp"
#include "drivers/status.hpp"

namespace standcal::drivers::can {

// One received frame as the kernel delivers it (classic frames use the first 8 bytes).
struct ReceivedFrame {
  std::uint32_t can_id = 0;  // with CAN_EFF_FLAG / CAN_ERR_FLAG / CAN_RTR_FLAG bits
  std::uint8_t len = 0;
  std::uint8_t data[64] = {};
  bool fd_frame = false;     // arrived as struct canfd_frame
  double t_s = 0;            // receive time, CLOCK_REALTIME seconds
  bool kernel_time = false;  // t_s came from SO_TIMESTAMPNS, not clock_gettime
};

// Now on the clock ReceivedFrame::t_s is on (CLOCK_REALTIME, seconds), so callers can
// tell frames received before a moment from those after it.
double realtime_now_s();

// What a CAN error frame says about the controller (linux/can/error.h).
struct BusEvent {
  bool bus_off = false;
  bool error_passive = false;
  bool back_to_active = false;  // CAN_ERR_CRTL_ACTIVE
  bool restarted = false;       // CAN_ERR_RESTARTED
};
// Classifies an error frame (can_id has CAN_ERR_FLAG).
BusEvent classify_error_frame(std::uint32_t can_id, const std::uint8_t* data, std::size_t len);
// Applies an error frame's news to a bus state; returns true when a restart was reported.
bool apply_bus_event(const BusEvent& e, BusState& state);

class CanLink {
 public:
  // Opens a raw CAN socket bound to `iface`, receiving only `ids` plus error frames,
  // with CAN FD frames enabled when the interface's MTU allows them.
  static Result<CanLink> open(const std::string& iface, const std::vector<std::uint32_t>& ids);
  // Takes ownership of an fd carrying CAN frame datagrams; `name` appears in messages.
  static Result<CanLink> adopt(int fd, std::string name);

  CanLink(CanLink&& other) noexcept;
  CanLink& operator=(CanLink&& other) noexcept;
  CanLink(const CanLink&) = delete;
  CanLink& operator=(const CanLink&) = delete;
  ~CanLink();

  // Receives one frame: true = got one, false = none queued; error when the link broke.
  Result<bool> receive(ReceivedFrame& out);
  // Sends one frame: struct can_frame when len <= 8 and not `fd`, else struct canfd_frame.
  Status send(std::uint32_t can_id, const std::uint8_t* data, std::uint8_t len, bool fd = false);

  int fd() const { return fd_; }
  const std::string& name() const { return name_; }
  bool fd_capable() const { return fd_capable_; }

 private:
  CanLink(int fd, std::string name, bool fd_capable)
      : fd_(fd), name_(std::move(name)), fd_capable_(fd_capable) {}
  int fd_ = -1;
  std::string name_;
  bool fd_capable_ = false;
  std::uint64_t malformed_ = 0;  // datagrams that were not CAN frames
};

}  // namespace standcal::drivers::can
