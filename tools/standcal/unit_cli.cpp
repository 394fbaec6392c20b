// `standcal unit --can IFACE read --seconds S`: bring-up of the accelerometer unit on
// CAN — per-axis mean and sigma, sample rate, incomplete samples, bus state.
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "drivers/socketcan/socketcan_unit.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"

namespace standcal::cli {
namespace {

namespace can = standcal::drivers::can;

struct UnitOptions {
  std::string can_iface;
  int fd = -1;
  std::string layout_file;
  double silence_s = 0.5;
  double seconds = 1;
};

std::unique_ptr<can::SocketCanUnit> open_unit(const UnitOptions& o) {
  if (o.can_iface.empty() && o.fd < 0) throw std::runtime_error("give --can IFACE (or --fd N)");
  auto layout = o.layout_file.empty()
                    ? drivers::Result<can::FrameLayout>(can::FrameLayout::default_layout())
                    : can::FrameLayout::from_file(o.layout_file);
  if (!layout) throw std::runtime_error(layout.status().message);
  const can::SocketCanUnitConfig config{o.silence_s, 4};
  auto unit = o.can_iface.empty() ? can::SocketCanUnit::adopt_fd(o.fd, layout.value(), config)
                                  : can::SocketCanUnit::open(o.can_iface, layout.value(), config);
  if (!unit) throw std::runtime_error(unit.status().message);
  return std::move(unit.value());
}

void read_unit(const UnitOptions& o) {
  auto unit = open_unit(o);
  if (auto s = unit->start(); !s) throw std::runtime_error(s.message);
  auto r = unit->collect(o.seconds);
  if (!r) throw std::runtime_error(r.status().message);
  const auto& samples = r.value();
  const auto h = unit->health();
  if (samples.empty())
    throw std::runtime_error("no complete sample from the accelerometer unit on " + unit->name() +
                             " in " + std::to_string(o.seconds) + " s");
  const double n = static_cast<double>(samples.size());
  const double span_s = samples.back().t_s - samples.front().t_s;
  const double rate_hz = samples.size() > 1 && span_s > 0 ? (n - 1) / span_s : 0;
  std::printf(
      "accelerometer unit on %s: %zu samples in %g s (%.1f Hz), %llu incomplete, %llu duplicate "
      "frames, "
      "%llu late frames, bus %s, %llu restarts\n",
      unit->name().c_str(), samples.size(), o.seconds, rate_hz,
      static_cast<unsigned long long>(h.incomplete_samples),
      static_cast<unsigned long long>(h.duplicate_frames),
      static_cast<unsigned long long>(h.late_frames), drivers::bus_state_name(h.bus_state),
      static_cast<unsigned long long>(h.restarts));
  std::printf("axis %16s %14s %14s %12s\n", "mean_mps2", "sigma_mps2", "mean_g", "sigma_ug");
  for (std::size_t a = 0; a < 3; ++a) {
    double sum = 0, sum_sq = 0;
    for (const auto& s : samples) sum += s.force_mps2[a];
    const double mean = sum / n;
    for (const auto& s : samples) sum_sq += (s.force_mps2[a] - mean) * (s.force_mps2[a] - mean);
    const double sigma = samples.size() > 1 ? std::sqrt(sum_sq / (n - 1)) : 0;
    std::printf("%-4s %16.7f %14.7f %14.9f %12.2f\n",
                a == 0   ? "x"
                : a == 1 ? "y"
                         : "z",
                mean, sigma, mean / can::kStandardGravity_mps2,
                sigma / can::kStandardGravity_mps2 * 1e6);
  }
  const double t_c = samples.back().temperature_c;
  if (std::isnan(t_c))
    std::printf("temperature: not reported\n");
  else
    std::printf("temperature: %.2f degC\n", t_c);
}

void add_unit_commands(CLI::App& app) {
  auto options = std::make_shared<UnitOptions>();
  auto* unit = app.add_subcommand("unit", "bring-up of the accelerometer unit over SocketCAN");
  unit->require_subcommand(1);
  auto* can_opt = unit->add_option("--can", options->can_iface, "CAN interface (e.g. can0)");
  auto* fd_opt =
      unit->add_option("--fd", options->fd, "inherited fd carrying CAN frame datagrams (tests)");
  can_opt->excludes(fd_opt);
  unit->add_option("--layout", options->layout_file,
                   "frame layout: JSON, or a DBC file (default: docs/unit-can.md)");
  unit->add_option("--silence-s", options->silence_s, "no frame this long means the unit is silent")
      ->check(cli_checks::kPositive);
  auto* read = unit->add_subcommand(
      "read", "sample for a while and print per-axis mean, sigma, rate, incomplete samples");
  read->add_option("--seconds", options->seconds, "how long to sample")
      ->check(cli_checks::kPositive);
  read->callback([options] { read_unit(*options); });
}

}  // namespace

static const bool unit_commands_registered = register_command_group(add_unit_commands);

}  // namespace standcal::cli
