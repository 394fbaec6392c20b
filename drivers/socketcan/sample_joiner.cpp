#include "drivers/socketcan/sample_joiner.hpp"

#include <algorithm>
#include <limits>

namespace standcal::drivers::can {

SampleJoiner::SampleJoiner(std::uint64_t counter_modulus, std::uint32_t join_window,
                           std::uint32_t resync_after)
    : modulus_(counter_modulus),
      window_(std::max<std::uint32_t>(join_window, 1)),
      resync_after_(std::max(resync_after, window_ + 1)),
      temperature_c_(std::numeric_limits<double>::quiet_NaN()) {}

// The unwrapped sequence number nearest to the newest one seen (half the modulus
// either way), so a 16-bit counter keeps counting through 65535 -> 0.
std::uint64_t SampleJoiner::unwrap(std::uint64_t counter) const {
  const std::uint64_t newest_mod = newest_seq_ % modulus_;
  const std::uint64_t ahead = (counter + modulus_ - newest_mod) % modulus_;
  if (ahead < modulus_ / 2) return newest_seq_ + ahead;
  const std::uint64_t behind = modulus_ - ahead;
  // Before the first wrap a far-behind counter cannot be unwrapped below zero: treat it as ahead.
  return behind <= newest_seq_ ? newest_seq_ - behind : newest_seq_ + ahead;
}

void SampleJoiner::restart_at(std::uint64_t seq) {
  for (const auto& p : pending_)
    if (p.mask != 0) ++counters_.incomplete_samples;
  pending_.clear();
  next_seq_ = newest_seq_ = seq;
  started_ = true;
  resolved_since_start_ = false;
}

void SampleJoiner::add(const FrameValues& frame, double t_s, std::vector<AccelSample>& out) {
  if (frame.has_temperature) temperature_c_ = frame.temperature_c;
  if (frame.force_mask == 0 || !frame.has_counter) return;
  const std::uint64_t counter = frame.counter % modulus_;
  if (!started_) {
    restart_at(counter);
  } else {
    const std::uint64_t seq = unwrap(counter);
    const bool far_ahead = seq > next_seq_ + resync_after_;
    const bool far_behind = seq + resync_after_ < next_seq_;
    if (far_ahead || far_behind) {
      ++counters_.counter_resyncs;
      restart_at(seq);
    }
  }
  const std::uint64_t seq = unwrap(counter);
  if (seq < next_seq_ && !resolved_since_start_ && seq + window_ >= next_seq_) {
    // Reordered at the very start: the first frame seen was not of the oldest sample.
    while (next_seq_ > seq) {
      pending_.emplace_front();
      --next_seq_;
    }
  }
  if (seq < next_seq_) {
    const Resolved& h = history_[seq % history_.size()];
    if (h.seq == seq && (h.mask & frame.force_mask) != 0)
      ++counters_.duplicate_frames;
    else
      ++counters_.late_frames;
    return;
  }
  while (next_seq_ + pending_.size() <= seq) pending_.emplace_back();
  Pending& p = pending_[seq - next_seq_];
  if ((p.mask & frame.force_mask) != 0) {
    ++counters_.duplicate_frames;
    return;
  }
  if (p.mask == 0 || t_s < p.t_s) p.t_s = t_s;  // a sample's time is its earliest frame
  for (int axis = 0; axis < 3; ++axis)
    if (frame.force_mask & (1U << axis))
      p.force_mps2[static_cast<std::size_t>(axis)] =
          frame.force_mps2[static_cast<std::size_t>(axis)];
  p.mask = static_cast<std::uint8_t>(p.mask | frame.force_mask);
  newest_seq_ = std::max(newest_seq_, seq);
  resolve_ready(out);
}

void SampleJoiner::resolve_ready(std::vector<AccelSample>& out) {
  while (!pending_.empty()) {
    const bool complete = pending_.front().mask == 0x7;
    const bool given_up = newest_seq_ >= next_seq_ + window_;
    if (!complete && !given_up) return;
    resolve_head(out);
  }
}

void SampleJoiner::resolve_head(std::vector<AccelSample>& out) {
  const Pending& p = pending_.front();
  if (p.mask == 0x7) {
    out.push_back({p.t_s, p.force_mps2, temperature_c_, next_seq_});
    ++counters_.samples;
  } else {
    ++counters_.incomplete_samples;  // includes samples none of whose frames arrived
  }
  history_[next_seq_ % history_.size()] = {next_seq_, p.mask};
  pending_.pop_front();
  ++next_seq_;
  resolved_since_start_ = true;
}

void SampleJoiner::reset() {
  for (const auto& p : pending_)
    if (p.mask != 0) ++counters_.incomplete_samples;
  pending_.clear();
  started_ = false;
  history_.fill({});
}

}  // namespace standcal::drivers::can
