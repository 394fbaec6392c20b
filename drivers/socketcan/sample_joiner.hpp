#pragma once
// Joins the per-axis frames of one sample by their sample counter (docs/unit-can.md):
// a sample is delivered only when all three axes arrived; a sample still missing a
// frame when a frame `join_window` samples newer arrives is dropped as incomplete,
// never interpolated. Counters wrap; samples come out in counter order.
#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "drivers/accel_unit.hpp"
#include "drivers/socketcan/frame_layout.hpp"

namespace standcal::drivers::can {

struct JoinCounters {
  std::uint64_t samples = 0;             // complete samples delivered
  std::uint64_t incomplete_samples = 0;  // dropped: some axis frame missing or late
  std::uint64_t duplicate_frames = 0;    // an axis seen twice for one sample
  std::uint64_t late_frames = 0;         // frame for a sample already delivered or dropped
  std::uint64_t counter_resyncs = 0;     // counter jumped too far: joining restarted there
};

class SampleJoiner {
 public:
  // counter_modulus: 2^bits of the sample counter; join_window: how many samples newer
  // a frame may be before an unfinished sample is given up; resync_after: a larger jump
  // of the counter (unit restarted) restarts joining instead of counting lost samples.
  explicit SampleJoiner(std::uint64_t counter_modulus, std::uint32_t join_window = 4,
                        std::uint32_t resync_after = 256);

  // Adds one decoded frame received at t_s; samples it completes are appended to out.
  void add(const FrameValues& frame, double t_s, std::vector<AccelSample>& out);
  // Drops samples in progress (counted as incomplete) and forgets the counter.
  void reset();
  const JoinCounters& counters() const { return counters_; }

 private:
  struct Pending {
    std::array<double, 3> force_mps2{};
    double t_s = 0;
    std::uint8_t mask = 0;
  };
  struct Resolved {
    std::uint64_t seq = ~0ULL;
    std::uint8_t mask = 0;
  };
  std::uint64_t unwrap(std::uint64_t counter) const;
  void resolve_ready(std::vector<AccelSample>& out);
  void resolve_head(std::vector<AccelSample>& out);
  void restart_at(std::uint64_t seq);

  std::uint64_t modulus_;
  std::uint32_t window_;
  std::uint32_t resync_after_;
  bool started_ = false;
  bool resolved_since_start_ = false;  // a sample was delivered or dropped since (re)start
  std::uint64_t next_seq_ = 0;         // unwrapped counter of pending_.front()
  std::uint64_t newest_seq_ = 0;       // highest unwrapped counter seen
  std::deque<Pending> pending_;
  std::array<Resolved, 512>
      history_{};  // recently resolved samples, to tell duplicates from late frames
  double temperature_c_;
  JoinCounters counters_;
};

}  // namespace standcal::drivers::can
