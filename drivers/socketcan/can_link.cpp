#include "drivers/socketcan/can_link.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <utility>

namespace standcal::drivers::can {
namespace {

std::string errno_text() { return std::strerror(errno); }

Status set_nonblocking(int fd, const std::string& name) {
  const int flags = fcntl(fd, F_GETFL);
  if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0)
    return Status::error(ErrorKind::link, "cannot make " + name + " non-blocking: " + errno_text());
  return Status::ok();
}

}  // namespace

double realtime_now_s() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

BusEvent classify_error_frame(std::uint32_t can_id, const std::uint8_t* data, std::size_t len) {
  BusEvent e;
  e.bus_off = (can_id & CAN_ERR_BUSOFF) != 0;
  e.restarted = (can_id & CAN_ERR_RESTARTED) != 0;
  if ((can_id & CAN_ERR_CRTL) != 0 && len > 1) {
    e.error_passive = (data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.back_to_active = (data[1] & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  return e;
}

bool apply_bus_event(const BusEvent& e, BusState& state) {
  if (e.restarted || e.back_to_active) state = BusState::error_active;
  if (e.error_passive && state != BusState::bus_off) state = BusState::error_passive;
  if (e.bus_off) state = BusState::bus_off;
  return e.restarted;
}

Result<CanLink> CanLink::open(const std::string& iface, const std::vector<std::uint32_t>& ids) {
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0)
    return Status::error(ErrorKind::link,
                         "cannot open a CAN socket for " + iface + ": " + errno_text() +
                             (errno == EAFNOSUPPORT ? " (kernel without CAN support)" : ""));
  CanLink link(fd, iface, false);
  ifreq ifr{};
  if (iface.size() >= sizeof(ifr.ifr_name))
    return Status::error(ErrorKind::invalid_argument,
                         "CAN interface name '" + iface + "' is too long");
  std::memcpy(ifr.ifr_name, iface.c_str(), iface.size() + 1);
  if (ioctl(fd, SIOCGIFINDEX, &ifr) < 0)
    return Status::error(ErrorKind::link, "no CAN interface " + iface + ": " + errno_text());
  // CAN FD frames only where the interface carries them (its MTU is CANFD_MTU).
  if (ioctl(fd, SIOCGIFMTU, &ifr) == 0 && ifr.ifr_mtu == static_cast<int>(CANFD_MTU)) {
    const int on = 1;
    link.fd_capable_ = setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) == 0;
  }
  std::vector<can_filter> filters;
  for (auto id : ids) {
    const bool ext = (id & CAN_EFF_FLAG) != 0;
    filters.push_back({id, CAN_EFF_FLAG | CAN_RTR_FLAG | (ext ? CAN_EFF_MASK : CAN_SFF_MASK)});
  }
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                 static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0)
    return Status::error(ErrorKind::link,
                         "cannot set CAN_RAW_FILTER on " + iface + ": " + errno_text());
  const can_err_mask_t err_mask =
      CAN_ERR_MASK;  // every error class: bus-off, controller state, restarts
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) < 0)
    return Status::error(ErrorKind::link,
                         "cannot enable CAN error frames on " + iface + ": " + errno_text());
  const int on = 1;
  setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);  // best effort: else clock_gettime
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0)
    return Status::error(ErrorKind::link,
                         "cannot bind a CAN socket to " + iface + ": " + errno_text());
  return link;
}

Result<CanLink> CanLink::adopt(int fd, std::string name) {
  if (fd < 0 || fcntl(fd, F_GETFD) < 0)
    return Status::error(ErrorKind::invalid_argument,
                         "fd " + std::to_string(fd) + " is not an open file descriptor");
  CanLink link(fd, std::move(name), true);
  if (auto s = set_nonblocking(fd, link.name_); !s) return s;
  fcntl(fd, F_SETFD, FD_CLOEXEC);
  const int on = 1;
  setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);  // not every fd type has it
  return link;
}

CanLink::CanLink(CanLink&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      name_(std::move(other.name_)),
      fd_capable_(other.fd_capable_),
      malformed_(other.malformed_) {}

CanLink& CanLink::operator=(CanLink&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    name_ = std::move(other.name_);
    fd_capable_ = other.fd_capable_;
    malformed_ = other.malformed_;
  }
  return *this;
}

CanLink::~CanLink() {
  if (fd_ >= 0) ::close(fd_);
}

Result<bool> CanLink::receive(ReceivedFrame& out) {
  canfd_frame frame{};
  iovec iov{&frame, sizeof frame};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) * 2];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  ssize_t n = 0;
  for (;;) {
    n = recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return false;
      return Status::error(ErrorKind::link,
                           "reading CAN frames from " + name_ + " failed: " + errno_text());
    }
    if (n == 0)
      return Status::error(ErrorKind::link, "CAN link " + name_ + " was closed by the other end");
    if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) {
      ++malformed_;  // not a CAN frame datagram: skip it
      msg.msg_controllen = sizeof control;
      continue;
    }
    break;
  }
  out.fd_frame = n == static_cast<ssize_t>(CANFD_MTU);
  out.can_id = frame.can_id;
  out.len = std::min<std::uint8_t>(frame.len, out.fd_frame ? CANFD_MAX_DLEN : CAN_MAX_DLEN);
  std::memcpy(out.data, frame.data, out.len);
  out.kernel_time = false;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      out.t_s = static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
      out.kernel_time = true;
    }
  }
  if (!out.kernel_time) out.t_s = realtime_now_s();
  return true;
}

Status CanLink::send(std::uint32_t can_id, const std::uint8_t* data, std::uint8_t len, bool fd) {
  canfd_frame frame{};
  frame.can_id = can_id;
  frame.len = std::min<std::uint8_t>(len, CANFD_MAX_DLEN);
  std::memcpy(frame.data, data, frame.len);
  const bool as_fd = fd || frame.len > CAN_MAX_DLEN;
  const std::size_t size = as_fd ? CANFD_MTU : CAN_MTU;  // struct can_frame is the first 16 bytes
  for (;;) {
    const ssize_t n = ::send(fd_, &frame, size, MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(size)) return Status::ok();
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == ENOBUFS))
      return Status::error(ErrorKind::timeout, "CAN transmit queue of " + name_ + " is full");
    return Status::error(ErrorKind::link,
                         "sending a CAN frame on " + name_ + " failed: " + errno_text());
  }
}

}  // namespace standcal::drivers::can
