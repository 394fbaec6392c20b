// The CAN frame decoder and the sample joiner (drivers/socketcan/frame_layout.hpp,
// sample_joiner.hpp): arbitrary frames, as a misbehaving unit or a noisy bus delivers
// them, through a classic 8-byte layout or a CAN FD layout.
//
// Input: byte 0 picks the layout (bit 0) and the join window (bits 1..4); then frames,
// each 4 bytes id (little-endian, CAN_EFF_FLAG in bit 31 as SocketCAN gives it), 1 byte
// length (mod 65), and that many payload bytes (fewer if the input ends).
// Properties: between counter resyncs the joiner hands out samples in strictly
// increasing counter order, and its sample count matches what it handed out.
#include <string>
#include <vector>

#include "drivers/socketcan/frame_layout.hpp"
#include "drivers/socketcan/sample_joiner.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace can = standcal::drivers::can;

namespace {

// A CAN FD layout: extended id, Intel order, 32-bit forces in mg, 12-bit counter.
can::FrameLayout fd_layout() {
  std::vector<can::SignalSpec> signals;
  const can::SignalRole forces[] = {can::SignalRole::force_x, can::SignalRole::force_y,
                                    can::SignalRole::force_z};
  for (int i = 0; i < 3; ++i) {
    can::SignalSpec s;
    s.name = "f" + std::to_string(i);
    s.role = forces[i];
    s.can_id = 0x18FF0010;
    s.extended = true;
    s.start_bit = 32 * i;
    s.length = 32;
    s.is_signed = true;
    s.scale = 1e-3;
    s.unit = "mg";
    signals.push_back(s);
  }
  can::SignalSpec counter;
  counter.name = "seq";
  counter.role = can::SignalRole::counter;
  counter.can_id = 0x18FF0010;
  counter.extended = true;
  counter.start_bit = 96;
  counter.length = 12;
  signals.push_back(counter);
  can::SignalSpec temp;
  temp.name = "temp";
  temp.role = can::SignalRole::temperature;
  temp.can_id = 0x18FF0011;
  temp.extended = true;
  temp.start_bit = 0;
  temp.length = 16;
  temp.is_signed = true;
  temp.scale = 0.01;
  temp.unit = "degC";
  signals.push_back(temp);
  auto layout = can::FrameLayout::from_signals(std::move(signals));
  if (!layout)
    standcal::fuzz::report_finding("can_frames: the harness's FD layout is invalid: " +
                                   layout.status().message);
  return layout.value();
}

const can::FrameLayout& pick_layout(std::uint8_t selector) {
  static const can::FrameLayout classic = can::FrameLayout::default_layout();
  static const can::FrameLayout fd = fd_layout();
  return (selector & 1) ? fd : classic;
}

std::uint32_t read_le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

void check_order(const std::vector<standcal::drivers::AccelSample>& out, std::size_t from,
                 bool& have_last, std::uint64_t& last_counter) {
  for (std::size_t i = from; i < out.size(); ++i) {
    if (have_last)
      standcal::fuzz::require(out[i].counter > last_counter,
                              "can_frames: sample counter " + std::to_string(out[i].counter) +
                                  " delivered after " + std::to_string(last_counter));
    have_last = true;
    last_counter = out[i].counter;
  }
}

}  // namespace

int standcal_fuzz_can_frames(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  return standcal::fuzz::expect_no_exceptions("can_frames", [&] {
    const can::FrameLayout& layout = pick_layout(data[0]);
    can::SampleJoiner joiner(layout.counter_modulus(),
                             static_cast<std::uint32_t>((data[0] >> 1) & 0x0F));
    std::vector<standcal::drivers::AccelSample> out;
    bool have_last = false;
    std::uint64_t last_counter = 0;
    std::size_t i = 1;
    double t_s = 0;
    while (i + 5 <= size) {
      const std::uint32_t id = read_le32(data + i);
      std::size_t len = data[i + 4] % 65;
      i += 5;
      if (len > size - i) len = size - i;
      can::FrameValues values;
      if (layout.decode(id, data + i, len, values)) {
        const std::size_t before = out.size();
        const std::uint64_t resyncs = joiner.counters().counter_resyncs;
        joiner.add(values, t_s, out);
        // A resync (the unit restarted its counter) legitimately starts counting anew.
        if (joiner.counters().counter_resyncs != resyncs) have_last = false;
        check_order(out, before, have_last, last_counter);
      }
      i += len;
      t_s += 0.001;
    }
    const auto& c = joiner.counters();
    standcal::fuzz::require(c.samples == out.size(),
                            "can_frames: the joiner's sample count " + std::to_string(c.samples) +
                                " differs from the " + std::to_string(out.size()) +
                                " samples delivered");
    joiner.reset();
  });
}
