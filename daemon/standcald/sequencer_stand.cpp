#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <thread>

#include "calib/text.hpp"
#include "daemon/standcald/dwell.hpp"
#include "daemon/standcald/sequencer.hpp"
#include "daemon/standcald/sequencer_detail.hpp"
#include "protocol/jsonrpc/methods.hpp"

// The sequencer's stand and unit commands and the stand operations a run uses (move, wait
// in position, stop, emergency stop), all on the sequencer thread.
namespace standcal::daemon {

// The sequencer files' shared names: sequencer_detail.hpp.
using namespace detail;

namespace {

constexpr double kCollectChunk_s = 1.0;  // unit time per collect() call: commands served between

protocol::AxisStatus axis_status(StandAxis axis, const drivers::Result<drivers::AxisState>& read) {
  protocol::AxisStatus a;
  a.axis = drivers::to_string(axis);
  if (!read) {
    a.error = read.status().message;
    return a;
  }
  const drivers::AxisState& s = read.value();
  a.mode = drivers::to_string(s.mode);
  a.angle_deg = s.angle_deg;
  a.enabled = s.enabled;
  a.homed = s.homed;
  a.estop = s.estop;
  a.stopped_by_heartbeat = s.stopped_by_heartbeat;
  a.fault_code = s.fault_code;
  a.fault_text = s.fault_text;
  return a;
}

}  // namespace

// --------------------------------------------------------------------------- stand commands
// Each answers one method while no run holds the stand (Sequencer::kBindings).

json Sequencer::enable_stand(const Command& cmd) {
  protocol::parse_no_params(cmd.params, cmd.method);
  prepare_stand(false);
  return protocol::EnabledResult{true};
}

json Sequencer::disable_stand(const Command& cmd) {
  protocol::parse_no_params(cmd.params, cmd.method);
  if (hw_.stand->lifecycle() == drivers::Lifecycle::active) {
    for (StandAxis a : kAxes) check(hw_.stand->disable(a));
  }
  return protocol::EnabledResult{false};
}

json Sequencer::home_stand(const Command& cmd) {
  protocol::parse_no_params(cmd.params, cmd.method);
  prepare_stand(false);
  home_axes();
  return protocol::HomedResult{read_axis(StandAxis::outer).angle_deg,
                               read_axis(StandAxis::inner).angle_deg};
}

json Sequencer::move_stand(const Command& cmd) {
  const auto request = protocol::StandMoveParams::parse(cmd.params);
  if (estop_latched_)
    throw RpcError(ErrorCode::estop_active, "emergency stop is latched: send estop.reset first");
  if (hw_.stand->lifecycle() != drivers::Lifecycle::active) {
    throw RpcError(ErrorCode::invalid_state, "the stand is not enabled: send stand.enable first");
  }
  for (StandAxis a : kAxes) {
    if (!read_axis(a).homed) {
      throw RpcError(ErrorCode::not_homed, std::string("stand axis ") + drivers::to_string(a) +
                                               " has not been homed: send stand.home first");
    }
  }
  if (!request.wait) {
    start_move(request.alpha1_deg, request.alpha2_deg);
    return protocol::MoveAccepted{};
  }
  auto [r1, r2] = move_and_wait(request.alpha1_deg, request.alpha2_deg);
  return protocol::MoveResult{r1, r2, true};
}

json Sequencer::reset_estop(const Command& cmd) {
  protocol::parse_no_params(cmd.params, cmd.method);
  // The latch is the controller's: an unconfigured stand is configured first so that a
  // latch set before then is found (it puts the stand in error) and reset here.
  if (hw_.stand->lifecycle() == drivers::Lifecycle::unconfigured) check(hw_.stand->configure());
  if (hw_.stand->lifecycle() == drivers::Lifecycle::error) check(hw_.stand->recover());
  estop_latched_ = false;
  return protocol::EstopResult{false, "emergency stop reset: send stand.enable and stand.home"};
}

json Sequencer::read_unit(const Command& cmd) {
  const double seconds = protocol::UnitReadParams::parse(cmd.params).seconds;
  // Shorter than one sample period reads nothing, and a mean of nothing is not 0.
  const double min_s = 1.0 / config_.sample_rate_hz;
  // The samples are averaged whole: at a high rate fewer seconds than an hour.
  const double max_s = std::min(3600.0, most_seconds_of(kMaxDwellSamples, config_.sample_rate_hz));
  if (!(seconds >= min_s && seconds <= max_s)) {
    // Said apart from the bound it is past (0.0099999 below 0.01, not 0.01 below 0.01).
    const auto [got, bound] = number_texts_apart(seconds, seconds < min_s ? min_s : max_s);
    throw RpcError(ErrorCode::invalid_params,
                   fmt::format("unit.read: \"seconds\" must be between {} (one sample at "
                               "unit.sample_rate_hz {:g} Hz) and {}{} (got {})",
                               seconds < min_s ? bound : number_text(min_s), config_.sample_rate_hz,
                               seconds < min_s ? number_text(max_s) : bound,
                               max_s < 3600 ? fmt::format(" ({:.0f} samples, what a read holds "
                                                          "at once)",
                                                          kMaxDwellSamples)
                                            : "",
                               got));
  }
  return unit_read(seconds);
}

// --------------------------------------------------------------------------- stand operations

drivers::AxisState Sequencer::read_axis(StandAxis axis) {
  return check(hw_.stand->read_state(axis));
}

void Sequencer::prepare_stand(bool home_if_needed) {
  drivers::Stand& s = *hw_.stand;
  if (estop_latched_)
    throw RpcError(ErrorCode::estop_active, "emergency stop is latched: send estop.reset first");
  if (s.lifecycle() == drivers::Lifecycle::error) {
    check(s.recover());
    // Let the driver's heartbeat run a few periods before the first move: a controller
    // whose watchdog tripped during the link loss refuses motion (exception 4) until it
    // has seen the heartbeat change again.
    wait_real(0.5);
  }
  if (s.lifecycle() == drivers::Lifecycle::unconfigured) check(s.configure());
  if (s.lifecycle() == drivers::Lifecycle::inactive) check(s.activate());
  for (StandAxis a : kAxes) {
    if (!read_axis(a).enabled) check(s.enable(a));
  }
  if (home_if_needed) {
    bool homed = true;
    for (StandAxis a : kAxes) homed = homed && read_axis(a).homed;
    if (!homed) home_axes();
  }
}

// The drivers' one in-position rule, on the stand's clock, serving requests while it waits.
drivers::WaitClock Sequencer::wait_clock() {
  return {[this] { return hw_.clock->now_s(); },
          [this](double stand_s) {
            wait_real(std::clamp(hw_.clock->real_seconds(stand_s), 0.002, 0.05));
          }};
}

void Sequencer::home_axes() {
  for (StandAxis a : kAxes) check(hw_.stand->home(a));
  check_wait(drivers::wait_homed(*hw_.stand, kAxes, config_.home_timeout_s,
                                 config_.in_position.poll_s, wait_clock()));
}

void Sequencer::start_move(double alpha1_deg, double alpha2_deg) {
  const double target[2] = {alpha1_deg, alpha2_deg};
  for (int i = 0; i < 2; ++i) {
    const StandAxis a = kAxes[i];
    const double now = read_axis(a).angle_deg;
    const double cmd = check(drivers::path_target_deg(hw_.stand->range(a), target[i], now));
    check(hw_.stand->move_to(a, cmd));
  }
}

std::pair<double, double> Sequencer::move_and_wait(double alpha1_deg, double alpha2_deg) {
  const double t1 = check(drivers::normalise_target_deg(
      hw_.stand->range(StandAxis::outer), alpha1_deg, read_axis(StandAxis::outer).angle_deg));
  const double t2 = check(drivers::normalise_target_deg(
      hw_.stand->range(StandAxis::inner), alpha2_deg, read_axis(StandAxis::inner).angle_deg));
  start_move(alpha1_deg, alpha2_deg);
  return wait_in_position(t1, t2);
}

std::pair<double, double> Sequencer::wait_in_position(double target1_deg, double target2_deg) {
  const drivers::AxisTarget targets[] = {{StandAxis::outer, target1_deg},
                                         {StandAxis::inner, target2_deg}};
  const std::vector<double> reached =
      check_wait(drivers::wait_in_position(*hw_.stand, targets, config_.in_position, wait_clock()));
  return {reached[0], reached[1]};
}

void Sequencer::stop_axes_quietly() {
  // Also in `error` and `inactive`: after a link loss mid-move the driver's heartbeat
  // keeps the controller alive once the link is back, so without this stop an axis would
  // carry on to its last target while the run reports a fault.
  if (hw_.stand->lifecycle() == drivers::Lifecycle::unconfigured) return;
  for (StandAxis a : kAxes) {
    const drivers::Status s = hw_.stand->stop(a);
    if (!s) spdlog::warn("stopping stand axis {}: {}", drivers::to_string(a), s.message);
  }
}

bool Sequencer::stop_axes_and_wait() {
  stop_axes_quietly();
  const double start_s = hw_.clock->now_s();
  const double poll_real =
      std::clamp(hw_.clock->real_seconds(config_.in_position.poll_s), 0.002, 0.05);
  while (!axes_still()) {
    if (hw_.clock->now_s() - start_s > config_.in_position.timeout_s) {
      spdlog::warn("the stand axes were still moving {} s after the stop command",
                   int(config_.in_position.timeout_s));
      refresh_stand_snapshot();
      return false;
    }
    heartbeat_++;
    handle_emergency_stops();
    std::this_thread::sleep_for(std::chrono::duration<double>(poll_real));
  }
  refresh_stand_snapshot();
  return true;
}

// While the axes decelerate no other command runs, but an emergency stop never waits for
// them: a stuck or runaway axis is when it is needed (the wait lasts up to
// in_position.timeout_s).
void Sequencer::handle_emergency_stops() {
  for (;;) {
    std::optional<Command> estop;
    {
      std::lock_guard lock(queue_mutex_);
      const auto it = std::find_if(queue_.begin(), queue_.end(),
                                   [](const Command& c) { return c.method == m::estop; });
      if (it == queue_.end()) return;
      estop = std::move(*it);
      queue_.erase(it);
    }
    handle(*estop);
  }
}

bool Sequencer::axes_still() {
  if (hw_.stand->lifecycle() == drivers::Lifecycle::unconfigured) return true;
  for (StandAxis a : kAxes) {
    const auto state = hw_.stand->read_state(a);
    if (!state)
      return true;  // unreadable: the link fault is reported by whoever needs the stand next
    const drivers::AxisMode mode = state.value().mode;
    if (mode == drivers::AxisMode::moving || mode == drivers::AxisMode::homing) return false;
  }
  return true;
}

void Sequencer::emergency_stop(const std::string& requested_by) {
  estop_latched_ = true;
  const drivers::Status s = hw_.stand->emergency_stop();
  // Who pressed it is the first question afterwards.
  spdlog::warn("EMERGENCY STOP requested by {}", requested_by.empty() ? "a client" : requested_by);
  refresh_stand_snapshot();
  protocol::FaultEvent fault;
  fault.message = "emergency stop: both axes stopped and disabled";
  fault.source = "estop";
  events_(ev::fault, fault);
  if (!s)
    throw RpcError(ErrorCode::hardware_fault,
                   "emergency stop could not be confirmed by the stand: " + s.message);
}

void Sequencer::refresh_stand_snapshot() {
  protocol::StandStatus snapshot;
  snapshot.name = hw_.stand->name();
  snapshot.id = config_.stand_id;
  snapshot.lifecycle = drivers::to_string(hw_.stand->lifecycle());
  snapshot.estop_latched = estop_latched_;
  for (StandAxis a : kAxes) snapshot.axes.push_back(axis_status(a, hw_.stand->read_state(a)));
  const drivers::AccelUnitHealth h = hw_.unit->health();
  snapshot.unit = {hw_.unit->name(), h.samples, h.incomplete_samples,
                   drivers::bus_state_name(h.bus_state), h.silent};
  if (mode_ == Mode::command) snapshot.busy_with = busy_with_;
  std::lock_guard lock(snapshot_mutex_);
  stand_snapshot_ = std::move(snapshot);
}

// --------------------------------------------------------------------------- unit

void Sequencer::collect(double seconds, const SampleChunkFn& take) {
  // The chunks after the first continue the unit's series from where the previous one's
  // window ended (collect_more), so each also holds what came while this thread served
  // commands before it, and the unit's clock makes the chunks' lengths add up to `seconds`.
  // (Timed here, the series had begun at a clock read before the first call: a millisecond
  // lost between the two under load was 0.3 s of the unit's time at 300x, 33 samples short.)
  double chunk_s = 0;
  for (double left_s = seconds; left_s > 1e-9; left_s -= chunk_s) {
    service();
    const bool first = left_s == seconds;
    chunk_s = std::min(left_s, kCollectChunk_s);
    auto got = check(first ? hw_.unit->collect(chunk_s) : hw_.unit->collect_more(chunk_s));
    take(std::move(got));
  }
  service();  // what came during the last chunk, before the dwell is taken (an abort drops it)
}

void Sequencer::sample_unit(double seconds, const SampleChunkFn& take) {
  check(hw_.unit->start());
  try {
    collect(seconds, take);
  } catch (...) {
    (void)hw_.unit->stop();
    throw;
  }
  (void)hw_.unit->stop();
}

std::vector<drivers::AccelSample> Sequencer::sample_unit(double seconds) {
  std::vector<drivers::AccelSample> all;
  // Reserved for the configured rate (and a little over): grown by doubling, a long dwell's
  // vector had held up to twice its samples' memory.
  all.reserve(static_cast<std::size_t>(
      std::min(seconds * config_.sample_rate_hz * 1.01 + 16, kMaxDwellSamples * 1.01)));
  sample_unit(seconds, [&](std::vector<drivers::AccelSample>&& chunk) {
    all.insert(all.end(), chunk.begin(), chunk.end());
  });
  return all;
}

protocol::UnitReadResult Sequencer::unit_read(double seconds) {
  const std::vector<drivers::AccelSample> samples = sample_unit(seconds);
  if (samples.empty()) {
    throw RpcError(
        ErrorCode::hardware_fault,
        fmt::format(
            "unit.read: no sample from the accelerometer unit during {:g} s (is it powered and "
            "on the bus?)",
            seconds));
  }
  const DwellAverage s = average_dwell(samples);
  const auto axis = [&](int a) {
    return protocol::UnitAxisReading{s.mean_mps2[a], s.sigma_mps2[a] / config_.g_local_mps2 * 1e6};
  };
  protocol::UnitReadResult r;
  r.samples = s.count;
  r.rate_hz = seconds > 0 ? s.count / seconds : 0.0;
  r.axes = {axis(0), axis(1), axis(2)};
  if (std::isfinite(s.temp_mean_c)) r.temp_c = s.temp_mean_c;
  r.incomplete_samples = hw_.unit->health().incomplete_samples;
  return r;
}

}  // namespace standcal::daemon
