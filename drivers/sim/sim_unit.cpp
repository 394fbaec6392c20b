#include "drivers/sim/sim_unit.hpp"

#include <cmath>

namespace standcal::drivers {

SimUnit::SimUnit(std::shared_ptr<const SimClock> clock, std::shared_ptr<const SimStand> stand,
                 const TruthModel& truth, std::uint64_t seed, double sample_rate_hz)
    : clock_(std::move(clock)),
      stand_(std::move(stand)),
      sample_rate_hz_(sample_rate_hz),
      simulator_(truth, seed, sample_rate_hz) {}

Status SimUnit::start() {
  std::lock_guard lock(mutex_);
  started_ = true;
  collected_since_start_ = false;
  restart_grid(clock_->now_s());
  return Status::ok();
}

Status SimUnit::stop() {
  std::lock_guard lock(mutex_);
  started_ = false;
  return Status::ok();
}

Result<std::vector<AccelSample>> SimUnit::collect(double seconds) {
  return collect_from(seconds, false);
}

Result<std::vector<AccelSample>> SimUnit::collect_more(double seconds) {
  return collect_from(seconds, true);
}

Result<std::vector<AccelSample>> SimUnit::collect_from(double seconds, bool continuing) {
  if (!(seconds > 0))
    return Status::error(ErrorKind::invalid_argument, "collect needs seconds > 0");  // NaN too
  double t_end_s = 0;
  {
    std::lock_guard lock(mutex_);
    if (!started_) return Status::error(ErrorKind::not_allowed, "sim unit is not started");
    // Samples on a fixed grid from the call on, or continued (collect_more): at a time scale
    // of 2000 the caller's millisecond between two chunks of a dwell is two seconds of the
    // unit's, which restarting the grid at each call had dropped (a quarter of a two-hour
    // dwell at 25 Hz: its Allan curves then showed a wander of 60 s as one of 45 s). A
    // continued series' window begins where the previous one ended, however late this call
    // comes, so its chunks' lengths add up to the series' span (a dwell then spans what the
    // caller asked for, not that plus the time the caller's thread lost before each call).
    if (!(continuing && collected_since_start_)) {
      const double now_s = clock_->now_s();
      if (grid_time_s(next_sample_) < now_s) restart_grid(now_s);
      series_end_s_ = now_s - grid_origin_s_;
    }
    collected_since_start_ = true;
    series_end_s_ += seconds;
    t_end_s = grid_origin_s_ + series_end_s_;
  }
  clock_->sleep_s(t_end_s - clock_->now_s());  // none where the window has passed already
  std::lock_guard lock(mutex_);
  if (silent_) {
    health_.silent = true;
    return Status::error(ErrorKind::timeout, "no data from the accelerometer unit (sim) for " +
                                                 std::to_string(seconds) +
                                                 " s: the unit is silent");
  }
  health_.silent = false;
  std::vector<AccelSample> out;
  out.reserve(static_cast<std::size_t>(seconds * sample_rate_hz_) + 1);
  // The grid's samples before the window's end; the end's own instant is the next window's
  // (sample numbers counted from the grid's origin, and the end kept as an offset from it, so
  // that rounding does not move a sample across at any clock reading).
  const double end_sample = series_end_s_ * sample_rate_hz_ - 1e-6;
  for (; static_cast<double>(next_sample_) < end_sample; ++next_sample_) {
    const double t_s = grid_time_s(next_sample_);
    const auto angles = stand_->angles_at_deg(t_s);
    const Vec3 f = simulator_.specific_force_mps2(t_s, angles[0], angles[1], mount_);
    AccelSample s;
    s.t_s = t_s;
    s.force_mps2 = {f.x(), f.y(), f.z()};
    s.temperature_c = simulator_.temperature_c(t_s);
    s.counter = counter_++;
    out.push_back(s);
  }
  health_.frames += 4 * out.size();
  health_.samples += out.size();
  return out;
}

void SimUnit::restart_grid(double origin_s) {
  grid_origin_s_ = origin_s;
  next_sample_ = 0;
}

double SimUnit::grid_time_s(std::uint64_t sample) const {
  return grid_origin_s_ + static_cast<double>(sample) / sample_rate_hz_;
}

AccelUnitHealth SimUnit::health() const {
  std::lock_guard lock(mutex_);
  return health_;
}

void SimUnit::remount(Mount mount) {
  std::lock_guard lock(mutex_);
  mount_ = mount;
}

void SimUnit::set_silent(bool silent) {
  std::lock_guard lock(mutex_);
  silent_ = silent;
}

}  // namespace standcal::drivers
