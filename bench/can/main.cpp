// standcal-bench-can: frames decoded and joined per second on one core (the target is
// >= 1 000 000/s; a saturated 1 Mbit/s bus carries about 8 000). Decoding and joining
// only: the frames are prepared in memory, as recvmsg would hand them over.
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "drivers/socketcan/frame_layout.hpp"
#include "drivers/socketcan/sample_joiner.hpp"

namespace {

using namespace standcal::drivers;
using namespace standcal::drivers::can;

struct Frame {
  std::uint32_t can_id;
  std::uint8_t len;
  std::uint8_t data[8];
};

std::vector<Frame> make_frames(const FrameLayout& layout, std::size_t samples) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0, 1e-3);
  std::vector<Frame> frames;
  frames.reserve(samples * 4);
  for (std::size_t n = 0; n < samples; ++n)
    for (const auto& e : layout.encode({noise(rng), 9.80665 + noise(rng), noise(rng)}, 25, n)) {
      Frame f{e.can_id, e.len, {}};
      std::copy(e.data.begin(), e.data.begin() + 8, f.data);
      frames.push_back(f);
    }
  return frames;
}

}  // namespace

int main() {
  const auto layout = FrameLayout::default_layout();
  const auto frames = make_frames(layout, 250000);  // 1 000 000 frames, counter wraps 3 times
  std::vector<AccelSample> out;
  out.reserve(260000);
  double best_decode = 0, best_join = 0;
  std::uint64_t samples = 0;
  for (int round = 0; round < 5; ++round) {
    FrameValues v;
    std::uint64_t decoded = 0;
    auto t0 = std::chrono::steady_clock::now();
    for (const auto& f : frames) decoded += layout.decode(f.can_id, f.data, f.len, v) ? 1 : 0;
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best_decode = std::max(best_decode, static_cast<double>(decoded) / s);

    SampleJoiner joiner(layout.counter_modulus());
    out.clear();
    t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < frames.size(); ++i)
      if (layout.decode(frames[i].can_id, frames[i].data, frames[i].len, v))
        joiner.add(v, static_cast<double>(i), out);
    s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best_join = std::max(best_join, static_cast<double>(frames.size()) / s);
    samples = joiner.counters().samples;
    if (joiner.counters().incomplete_samples != 0) {
      std::fprintf(stderr, "bench: %llu incomplete samples on clean input\n",
                   static_cast<unsigned long long>(joiner.counters().incomplete_samples));
      return 1;
    }
  }
  std::printf(
      "frames per round: %zu (default layout: 3 force frames + 1 temperature frame per sample)\n",
      frames.size());
  std::printf("decoded only:        %12.0f frames/s\n", best_decode);
  std::printf(
      "decoded and joined:  %12.0f frames/s  (%llu samples per round, target >= 1000000 "
      "frames/s)\n",
      best_join, static_cast<unsigned long long>(samples));
  return 0;
}
