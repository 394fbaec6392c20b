#pragma once
// The accelerometer unit on a CAN bus: CanLink (transport) + FrameLayout (decoder) +
// SampleJoiner (per-axis frames -> samples), driven by epoll, with silence detection
// and error-frame reporting (docs/unit-can.md).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drivers/accel_unit.hpp"
#include "drivers/socketcan/can_link.hpp"
#include "drivers/socketcan/frame_layout.hpp"
#include "drivers/socketcan/sample_joiner.hpp"

namespace standcal::drivers::can {

struct SocketCanUnitConfig {
  double silence_timeout_s = 0.5;  // no unit frame this long -> silent, sampling fails
  std::uint32_t join_window = 4;   // samples a frame may lag before its sample is given up
};

class SocketCanUnit final : public AccelUnit {
 public:
  // Opens the unit on a CAN interface ("can0").
  static Result<std::unique_ptr<SocketCanUnit>> open(const std::string& iface, FrameLayout layout,
                                                     SocketCanUnitConfig config = {});
  // Uses an fd that carries CAN frame datagrams (socketpair, inherited fd); takes ownership.
  static Result<std::unique_ptr<SocketCanUnit>> adopt_fd(int fd, FrameLayout layout,
                                                         SocketCanUnitConfig config = {});

  SocketCanUnit(CanLink link, FrameLayout layout, SocketCanUnitConfig config);
  ~SocketCanUnit() override;
  SocketCanUnit(const SocketCanUnit&) = delete;
  SocketCanUnit& operator=(const SocketCanUnit&) = delete;

  std::string name() const override { return link_.name(); }
  Status start() override;
  Status stop() override;
  Result<std::vector<AccelSample>> collect(double seconds) override;
  Result<std::vector<AccelSample>> collect_more(double seconds) override;
  AccelUnitHealth health() const override;

 private:
  // Samples with the time their last frame was received, on the monotonic clock.
  struct ReceivedSamples {
    std::vector<AccelSample> samples;
    std::vector<double> received_mono_s;
    void drop_before(double mono_s);
    ReceivedSamples take_from(double mono_s);
    void keep_if(const std::function<bool(double)>& keep);
  };

  Result<std::vector<AccelSample>> collect_from(double seconds, bool continuing);
  Status read_queued(ReceivedSamples* out);
  Status handle(const ReceivedFrame& f, double received_mono_s, std::vector<AccelSample>& out);
  Status silence_error() const;
  Status bus_off_error() const;

  CanLink link_;
  FrameLayout layout_;
  SocketCanUnitConfig config_;
  SampleJoiner joiner_;
  int epoll_fd_ = -1;
  bool running_ = false;
  bool collected_since_start_ = false;  // collect_more keeps every queued frame
  bool bus_off_seen_ = false;           // a bus-off arrived while collecting
  bool stamped_at_read_ = false;        // a frame since start() had no kernel receive stamp
  double last_unit_frame_mono_s_ = 0;
  double series_deadline_mono_s_ = 0;  // where the last collect's window ended
  ReceivedSamples held_;               // received after it: the next collect_more's first
  AccelUnitHealth health_;
};

}  // namespace standcal::drivers::can
