// standcal-can-emu: a simulated accelerometer unit on a CAN bus. Emits the frames of
// the configured layout (docs/unit-can.md) at a fixed rate to a CAN interface or an
// inherited fd, with the physics of calib/model.hpp plus white noise, and with
// injectable loss, duplication, reordering, silence and bus-off for testing the driver
// and the daemon (a control file changes the faults while it runs).
#include <linux/can.h>
#include <linux/can/error.h>
#include <poll.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "calib/model.hpp"
#include "calib/units.hpp"
#include "drivers/socketcan/can_link.hpp"
#include "drivers/socketcan/frame_layout.hpp"
#include "standcal/version.hpp"
#include "tools/cli_checks.hpp"

namespace {

using standcal::drivers::can::CanLink;
using standcal::drivers::can::EncodedFrame;
using standcal::drivers::can::FrameLayout;

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop = true; }

struct EmuOptions {
  std::string can_iface;
  int fd = -1;
  std::string layout_file;
  double rate_hz = 100;
  double alpha1_deg = 0, alpha2_deg = 0;
  std::vector<double> bias_ug{0, 0, 0}, scale_ppm{0, 0, 0}, gamma_arcsec{0, 0, 0};
  double noise_ug_rthz = 10;
  double gravity_mps2 = 9.80665;
  double temperature_c = 25;
  std::uint64_t seed = 1;
  std::uint64_t counter_start = 0;
  std::uint64_t samples = 0;  // 0 = until stopped
  double loss = 0, duplicate = 0, reorder = 0;
  double silence_after_s = -1, silence_for_s = 0;
  std::string control_file;  // fault lines, re-read when changed (see ControlFile)
};

// Faults switched while the emulator runs (tests start a fault at a chosen point of a
// run). One per line; the file's content replaces the previous one:
//   silence          no frame at all while the line is there
//   loss P           each frame lost with probability P (replaces --loss)
//   duplicate P      each frame sent twice with probability P (replaces --duplicate)
//   bus_off [MS]     once per change of the file: an error frame "bus-off", MS ms
//                    (default 300) without frames, then an error frame "restarted"
class ControlFile {
 public:
  explicit ControlFile(std::string path) : path_(std::move(path)) {}

  struct State {
    bool silence = false;
    std::optional<double> loss, duplicate;
    int bus_off_ms = -1;  // >= 0: a bus-off to play now
  };

  // Re-reads the file at most every 50 ms; true when its content changed.
  bool poll(double now_s, State& state) {
    if (path_.empty() || now_s < next_poll_s_) return false;
    next_poll_s_ = now_s + 0.05;
    std::ifstream in(path_);
    std::stringstream text;
    text << in.rdbuf();
    if (text.str() == content_) return false;
    content_ = text.str();
    state = State{};
    for (std::string line; std::getline(text, line);) {
      std::istringstream words(line);
      std::string word;
      if (!(words >> word) || word[0] == '#') continue;
      double value = 0;
      if (word == "silence") {
        state.silence = true;
      } else if (word == "loss" && words >> value) {
        state.loss = value;
      } else if (word == "duplicate" && words >> value) {
        state.duplicate = value;
      } else if (word == "bus_off") {
        state.bus_off_ms = words >> value ? static_cast<int>(value) : 300;
      } else {
        std::fprintf(stderr, "standcal-can-emu: bad control line '%s' (ignored)\n", line.c_str());
      }
    }
    return true;
  }

 private:
  std::string path_;
  std::string content_;
  double next_poll_s_ = 0;
};

struct EmuCounters {
  std::uint64_t samples = 0, frames_sent = 0, lost = 0, duplicated = 0, reordered = 0, tx_full = 0;
};

// The noise-free output of the unit (model.md: J = Delta + (I+dK)(I+Gamma) u_true), in m/s^2.
standcal::Vec3 true_force_mps2(const EmuOptions& o) {
  standcal::UnitErrors unit;
  for (int i = 0; i < 3; ++i) {
    unit.bias_g[i] = o.bias_ug[static_cast<std::size_t>(i)] * standcal::kUg;
    unit.scale[i] = o.scale_ppm[static_cast<std::size_t>(i)] * standcal::kPpm;
  }
  unit.set_gamma_pair_sums_rad(
      standcal::Vec3(o.gamma_arcsec[0], o.gamma_arcsec[1], o.gamma_arcsec[2]) *
      standcal::kArcsecToRad);
  const auto u = standcal::true_up_vector(o.alpha1_deg * standcal::kDegToRad,
                                          o.alpha2_deg * standcal::kDegToRad, standcal::Mount::x,
                                          standcal::StandErrors{});
  return standcal::unit_output_g(unit, u) * o.gravity_mps2;
}

double monotonic_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

void sleep_until(double t_s) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_s);
  ts.tv_nsec = static_cast<long>((t_s - static_cast<double>(ts.tv_sec)) * 1e9);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR && !g_stop) {
  }
}

// Sends one frame, waiting briefly while the transmit queue is full; false when the
// link is gone (the reader closed its end).
bool send_frame(CanLink& link, const EncodedFrame& f, EmuCounters& c) {
  for (int attempt = 0; attempt < 1000 && !g_stop; ++attempt) {
    const auto s = link.send(f.can_id, f.data.data(), f.len);
    if (s) {
      ++c.frames_sent;
      return true;
    }
    if (s.kind != standcal::drivers::ErrorKind::timeout) {
      std::fprintf(stderr, "standcal-can-emu: %s; stopping\n", s.message.c_str());
      return false;
    }
    pollfd p{link.fd(), POLLOUT, 0};
    poll(&p, 1, 1);
  }
  ++c.tx_full;
  return true;
}

// An error frame as the kernel reports controller events (linux/can/error.h).
bool send_error_frame(CanLink& link, std::uint32_t error_class, EmuCounters& c) {
  EncodedFrame f;
  f.can_id = CAN_ERR_FLAG | error_class;
  f.len = CAN_ERR_DLC;
  return send_frame(link, f, c);
}

int run(const EmuOptions& o, const FrameLayout& layout, CanLink& link) {
  const standcal::Vec3 f0 = true_force_mps2(o);
  const double sigma_mps2 =
      o.noise_ug_rthz * standcal::kUg * std::sqrt(o.rate_hz) * o.gravity_mps2;  // N*sqrt(fs)
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::optional<EncodedFrame> held;  // a frame held back to be sent after the next one
  EmuCounters c;
  ControlFile control(o.control_file);
  ControlFile::State live;
  double loss = o.loss, duplicate = o.duplicate;
  double quiet_until_s = -1;  // bus-off: no frames before this (emulator time)
  bool restart_pending = false;
  const double t0 = monotonic_s();
  for (std::uint64_t k = 0; !g_stop && (o.samples == 0 || k < o.samples); ++k) {
    const double t = static_cast<double>(k) / o.rate_hz;
    sleep_until(t0 + t);
    ++c.samples;
    if (control.poll(t, live)) {
      loss = live.loss.value_or(o.loss);
      duplicate = live.duplicate.value_or(o.duplicate);
      if (live.bus_off_ms >= 0) {
        if (!send_error_frame(link, CAN_ERR_BUSOFF, c)) return 0;
        quiet_until_s = t + live.bus_off_ms / 1000.0;
        restart_pending = true;
      }
    }
    if (restart_pending && t >= quiet_until_s) {
      if (!send_error_frame(link, CAN_ERR_RESTARTED, c)) return 0;
      restart_pending = false;
    }
    const bool silent = (o.silence_after_s >= 0 && t >= o.silence_after_s &&
                         (o.silence_for_s <= 0 || t < o.silence_after_s + o.silence_for_s)) ||
                        live.silence || restart_pending;
    std::array<double, 3> f{};
    for (int i = 0; i < 3; ++i) f[static_cast<std::size_t>(i)] = f0[i] + sigma_mps2 * gauss(rng);
    if (silent) continue;  // noise still advances: the sequence does not depend on silence
    for (const auto& frame : layout.encode(f, o.temperature_c, o.counter_start + k)) {
      if (uniform(rng) < loss) {
        ++c.lost;
        continue;
      }
      if (!held && uniform(rng) < o.reorder) {
        held = frame;
        ++c.reordered;
        continue;
      }
      const int copies = uniform(rng) < duplicate ? 2 : 1;
      c.duplicated += static_cast<std::uint64_t>(copies - 1);
      for (int n = 0; n < copies; ++n)
        if (!send_frame(link, frame, c)) return 0;
      if (held) {
        if (!send_frame(link, *held, c)) return 0;
        held.reset();
      }
    }
  }
  if (held) send_frame(link, *held, c);
  std::fprintf(
      stderr,
      "standcal-can-emu: %llu samples, %llu frames sent, %llu lost, %llu duplicated, %llu "
      "reordered, "
      "%llu dropped on a full transmit queue\n",
      static_cast<unsigned long long>(c.samples), static_cast<unsigned long long>(c.frames_sent),
      static_cast<unsigned long long>(c.lost), static_cast<unsigned long long>(c.duplicated),
      static_cast<unsigned long long>(c.reordered), static_cast<unsigned long long>(c.tx_full));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "standcal-can-emu: a simulated accelerometer unit emitting CAN frames (docs/unit-can.md)"};
  app.set_version_flag("--version", standcal::kVersionLine);
  EmuOptions o;
  auto* can = app.add_option("--can", o.can_iface, "CAN interface to send on (e.g. vcan0)");
  auto* fd = app.add_option("--fd", o.fd, "inherited file descriptor carrying CAN frame datagrams");
  can->excludes(fd);
  app.add_option("--layout", o.layout_file,
                 "frame layout: JSON, or a DBC file (default: the layout of docs/unit-can.md)");
  app.add_option("--rate-hz", o.rate_hz, "samples per second")->check(CLI::Range(0.001, 1e6));
  app.add_option("--alpha1-deg", o.alpha1_deg, "outer stand axis angle");
  app.add_option("--alpha2-deg", o.alpha2_deg, "inner stand axis angle");
  app.add_option("--bias-ug", o.bias_ug, "bias of x,y,z in micro-g")->delimiter(',')->expected(3);
  app.add_option("--scale-ppm", o.scale_ppm, "scale-factor error of x,y,z in ppm")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--gamma-arcsec", o.gamma_arcsec,
                 "non-orthogonality pair sums g12,g13,g23 in arcsec")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--noise-ug-rthz", o.noise_ug_rthz,
                 "white noise density N; one sample has sigma N*sqrt(rate)")
      ->check(standcal::cli_checks::kNonNegative);
  app.add_option("--gravity-mps2", o.gravity_mps2, "local gravity g");
  app.add_option("--temperature-c", o.temperature_c, "reported unit temperature");
  app.add_option("--seed", o.seed, "noise and fault-injection seed");
  app.add_option("--counter-start", o.counter_start, "first sample counter (to exercise the wrap)");
  app.add_option("--samples", o.samples,
                 "stop after this many samples (0: run until SIGTERM/SIGINT)");
  app.add_option("--loss", o.loss, "probability that a frame is lost")->check(CLI::Range(0.0, 1.0));
  app.add_option("--duplicate", o.duplicate, "probability that a frame is sent twice")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--reorder", o.reorder,
                 "probability that a frame is held back behind the next one")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--silence-after-s", o.silence_after_s,
                 "fall silent this many seconds after start");
  app.add_option("--silence-for-s", o.silence_for_s, "stay silent this long (0: for good)");
  app.add_option("--control", o.control_file,
                 "file of fault lines re-read while running: 'silence', 'loss P', 'duplicate P', "
                 "'bus_off [MS]'");
  CLI11_PARSE(app, argc, argv);

  if (o.can_iface.empty() && o.fd < 0) {
    std::fprintf(stderr, "standcal-can-emu: give --can IFACE or --fd N\n");
    return 1;
  }
  auto layout = o.layout_file.empty()
                    ? standcal::drivers::Result<FrameLayout>(FrameLayout::default_layout())
                    : FrameLayout::from_file(o.layout_file);
  if (!layout) {
    std::fprintf(stderr, "standcal-can-emu: %s\n", layout.status().message.c_str());
    return 1;
  }
  auto link = o.can_iface.empty() ? CanLink::adopt(o.fd, "fd " + std::to_string(o.fd))
                                  : CanLink::open(o.can_iface, {});
  if (!link) {
    std::fprintf(stderr, "standcal-can-emu: %s\n", link.status().message.c_str());
    return 1;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  return run(o, layout.value(), link.value());
}
