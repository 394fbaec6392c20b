#include "drivers/socketcan/socketcan_unit.hpp"

#include <linux/can.h>
#include <sys/epoll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <vector>

namespace standcal::drivers::can {
namespace {

double monotonic_now_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

}  // namespace

Result<std::unique_ptr<SocketCanUnit>> SocketCanUnit::open(const std::string& iface,
                                                           FrameLayout layout,
                                                           SocketCanUnitConfig config) {
  auto link = CanLink::open(iface, layout.can_ids());
  if (!link) return link.status();
  return std::make_unique<SocketCanUnit>(std::move(link.value()), std::move(layout), config);
}

Result<std::unique_ptr<SocketCanUnit>> SocketCanUnit::adopt_fd(int fd, FrameLayout layout,
                                                               SocketCanUnitConfig config) {
  auto link = CanLink::adopt(fd, "fd " + std::to_string(fd));
  if (!link) return link.status();
  return std::make_unique<SocketCanUnit>(std::move(link.value()), std::move(layout), config);
}

SocketCanUnit::SocketCanUnit(CanLink link, FrameLayout layout, SocketCanUnitConfig config)
    : link_(std::move(link)),
      layout_(std::move(layout)),
      config_(config),
      joiner_(layout_.counter_modulus(), config.join_window) {
  epoll_fd_ = epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ >= 0) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = link_.fd();
    epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, link_.fd(), &ev);
  }
}

SocketCanUnit::~SocketCanUnit() {
  if (epoll_fd_ >= 0) ::close(epoll_fd_);
}

Status SocketCanUnit::start() {
  if (epoll_fd_ < 0)
    return Status::error(ErrorKind::link,
                         "cannot watch CAN link " + link_.name() + ": epoll_create1 failed");
  running_ = true;
  collected_since_start_ = false;
  held_ = {};
  stamped_at_read_ = false;
  joiner_.reset();
  last_unit_frame_mono_s_ = monotonic_now_s();
  return read_queued(nullptr);  // frames queued before start: counted in health, not delivered
}

Status SocketCanUnit::stop() {
  running_ = false;
  return Status::ok();
}

Status SocketCanUnit::silence_error() const {
  return Status::error(ErrorKind::timeout, "no CAN frame from the accelerometer unit on " +
                                               link_.name() + " for " +
                                               seconds_text(config_.silence_timeout_s) + " s");
}

Result<std::vector<AccelSample>> SocketCanUnit::collect(double seconds) {
  return collect_from(seconds, false);
}

Result<std::vector<AccelSample>> SocketCanUnit::collect_more(double seconds) {
  return collect_from(seconds, true);
}

Result<std::vector<AccelSample>> SocketCanUnit::collect_from(double seconds, bool continuing) {
  if (!running_)
    return Status::error(ErrorKind::not_allowed,
                         "accelerometer unit on " + link_.name() + " is not started");
  if (!(seconds > 0))
    return Status::error(ErrorKind::invalid_argument, "sampling time must be positive");
  // A continued series begins with what the previous call held back (below), then the frames
  // queued since; a new one drops what was held.
  const bool keep_queued = continuing && collected_since_start_;
  ReceivedSamples got;
  if (keep_queued) got = std::move(held_);
  held_ = {};
  if (auto s = read_queued(&got); !s) return s;  // frames queued before this call
  // A bus-off since the last call with no restart after it: nothing can arrive.
  if (health_.bus_state == BusState::bus_off)
    return Status::error(ErrorKind::link, "CAN controller of " + link_.name() +
                                              " is bus-off (no restart since); the accelerometer "
                                              "unit cannot be sampled");
  // A silence already reported gives the unit a fresh silence timeout from this call:
  // after a cable is plugged back, the next collect must not fail before a frame can come.
  if (health_.silent)
    last_unit_frame_mono_s_ = std::max(last_unit_frame_mono_s_, monotonic_now_s());
  // From the call on, or (collect_more) from where the previous collect's window ended, with
  // what queued since: a dwell collected in chunks then loses no sample to the caller's time
  // between them, and its chunks' lengths add up to its span however late each call comes.
  const double start_mono_s = monotonic_now_s();
  const double deadline_s = (keep_queued ? series_deadline_mono_s_ : start_mono_s) + seconds;
  bus_off_seen_ = false;  // from here a bus-off fails the call, restarted or not
  for (;;) {
    const double now = monotonic_now_s();
    if (now - last_unit_frame_mono_s_ >= config_.silence_timeout_s) {
      health_.silent = true;
      joiner_.reset();
      return silence_error();
    }
    if (now >= deadline_s) break;
    const double wake_s = std::min(deadline_s, last_unit_frame_mono_s_ + config_.silence_timeout_s);
    const int timeout_ms = static_cast<int>(std::ceil((wake_s - now) * 1000.0));
    epoll_event ev{};
    const int n = epoll_wait(epoll_fd_, &ev, 1, std::max(timeout_ms, 1));
    if (n < 0 && errno != EINTR)
      return Status::error(ErrorKind::link, "waiting for CAN frames on " + link_.name() +
                                                " failed: " + std::strerror(errno));
    if (n > 0)
      if (auto s = read_queued(&got); !s) return s;
    if (bus_off_seen_) return bus_off_error();
  }
  if (!keep_queued) got.drop_before(start_mono_s);
  // What the kernel received after the window is the next window's (a frame stamped when it
  // was read, on a descriptor without SO_TIMESTAMPNS, cannot tell: all of it is returned).
  if (!stamped_at_read_) held_ = got.take_from(deadline_s);
  collected_since_start_ = true;
  series_deadline_mono_s_ = deadline_s;
  return std::move(got.samples);
}

void SocketCanUnit::ReceivedSamples::drop_before(double mono_s) {
  keep_if([&](double t) { return !(t < mono_s); });
}

// The samples received at or after `mono_s`, taken out in their order.
SocketCanUnit::ReceivedSamples SocketCanUnit::ReceivedSamples::take_from(double mono_s) {
  ReceivedSamples later;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (!(received_mono_s[i] < mono_s)) {
      later.samples.push_back(samples[i]);
      later.received_mono_s.push_back(received_mono_s[i]);
    }
  keep_if([&](double t) { return t < mono_s; });
  return later;
}

void SocketCanUnit::ReceivedSamples::keep_if(const std::function<bool(double)>& keep) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (keep(received_mono_s[i])) {
      samples[kept] = samples[i];
      received_mono_s[kept++] = received_mono_s[i];
    }
  samples.resize(kept);
  received_mono_s.resize(kept);
}

Status SocketCanUnit::bus_off_error() const {
  return Status::error(ErrorKind::link, "CAN controller of " + link_.name() +
                                            " went bus-off while sampling the accelerometer unit");
}

// Reads every queued frame; the samples they complete go to `out` (none: counted only). Their
// kernel receive stamps (wall-clock) are put on the monotonic clock at the two clocks' offset
// as this read finds it, so a clock step between two reads moves no sample's place in time.
Status SocketCanUnit::read_queued(ReceivedSamples* out) {
  const double mono_minus_real_s = monotonic_now_s() - realtime_now_s();
  ReceivedFrame f;
  std::vector<AccelSample> joined;
  for (;;) {
    auto r = link_.receive(f);
    if (!r) return r.status();
    if (!r.value()) return Status::ok();
    const double received_mono_s = f.kernel_time ? f.t_s + mono_minus_real_s : monotonic_now_s();
    joined.clear();
    if (auto s = handle(f, received_mono_s, joined); !s) return s;
    if (out == nullptr) continue;
    for (const AccelSample& a : joined) {
      out->samples.push_back(a);
      out->received_mono_s.push_back(received_mono_s);
    }
  }
}

Status SocketCanUnit::handle(const ReceivedFrame& f, double received_mono_s,
                             std::vector<AccelSample>& out) {
  if ((f.can_id & CAN_ERR_FLAG) != 0) {
    ++health_.error_frames;
    const BusEvent e = classify_error_frame(f.can_id, f.data, f.len);
    if (apply_bus_event(e, health_.bus_state)) ++health_.restarts;
    if (e.bus_off) bus_off_seen_ = true;
    return Status::ok();
  }
  FrameValues v;
  const std::uint32_t key =
      f.can_id & (CAN_EFF_FLAG | ((f.can_id & CAN_EFF_FLAG) ? CAN_EFF_MASK : CAN_SFF_MASK));
  if ((f.can_id & CAN_RTR_FLAG) != 0 || !layout_.decode(key, f.data, f.len, v)) {
    ++health_.unknown_frames;
    return Status::ok();
  }
  ++health_.frames;
  health_.silent = false;
  // A frame received is a controller back on the bus, whether or not its driver sent a
  // restart notice (not all do): a bus-off state left behind must not block sampling.
  if (health_.bus_state == BusState::bus_off) health_.bus_state = BusState::error_active;
  // When the unit last sent, not when this thread got to it: a caller late by more than the
  // silence timeout still finds a unit that fell silent meanwhile.
  last_unit_frame_mono_s_ = std::max(last_unit_frame_mono_s_, received_mono_s);
  if (!f.kernel_time) stamped_at_read_ = true;
  if (running_) joiner_.add(v, f.t_s, out);
  return Status::ok();
}

AccelUnitHealth SocketCanUnit::health() const {
  AccelUnitHealth h = health_;
  const JoinCounters& j = joiner_.counters();
  h.samples = j.samples;
  h.incomplete_samples = j.incomplete_samples;
  h.duplicate_frames = j.duplicate_frames;
  h.late_frames = j.late_frames;
  h.counter_resyncs = j.counter_resyncs;
  return h;
}

}  // namespace standcal::drivers::can
