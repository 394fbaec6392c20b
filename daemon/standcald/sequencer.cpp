#include "daemon/standcald/sequencer.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/compensation.hpp"
#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/recording.hpp"
#include "calib/recording_digest.hpp"
#include "calib/report.hpp"
#include "calib/utc_time.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "protocol/jsonrpc/text.hpp"
#include "standcal/version.hpp"

namespace standcal::daemon {

using drivers::StandAxis;
using nlohmann::json;
using protocol::ErrorCode;
using protocol::RpcError;
namespace m = protocol::method;
namespace st = protocol::run_state;
namespace ev = protocol::event;

namespace {

constexpr StandAxis kAxes[] = {StandAxis::outer, StandAxis::inner};
constexpr double kIdleRefreshReal_s = 1.0;  // idle: stand snapshot and heartbeat once a second
constexpr double kCollectChunk_s = 1.0;     // unit time per collect() call: commands served between

double now_real_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

ErrorCode code_for(drivers::ErrorKind kind) {
  switch (kind) {
    case drivers::ErrorKind::limit:
      return ErrorCode::limit;
    case drivers::ErrorKind::estop:
      return ErrorCode::estop_active;
    case drivers::ErrorKind::invalid_argument:
      return ErrorCode::invalid_params;
    case drivers::ErrorKind::not_allowed:
      return ErrorCode::invalid_state;
    default:
      return ErrorCode::hardware_fault;
  }
}

// Turns a failed driver call into the protocol error the operator sees.
void check(const drivers::Status& s) {
  if (!s) throw RpcError(code_for(s.kind), s.message);
}
template <class T>
const T& check(const drivers::Result<T>& r) {
  if (!r) throw RpcError(code_for(r.status().kind), r.status().message);
  return r.value();
}
// A wait that ended early: an axis that lost its drive mid-move is a hardware fault, not a
// refused request.
template <class T>
T check_wait(drivers::Result<T> r) {
  if (!r) {
    const drivers::ErrorKind kind = r.status().kind;
    throw RpcError(
        kind == drivers::ErrorKind::not_allowed ? ErrorCode::hardware_fault : code_for(kind),
        r.status().message);
  }
  return std::move(r.value());
}

json axis_json(StandAxis axis, const drivers::AxisState& s) {
  return json{{"axis", drivers::to_string(axis)},
              {"mode", drivers::to_string(s.mode)},
              {"angle_deg", s.angle_deg},
              {"enabled", s.enabled},
              {"homed", s.homed},
              {"estop", s.estop},
              {"stopped_by_heartbeat", s.stopped_by_heartbeat},
              {"fault_code", s.fault_code},
              {"fault_text", s.fault_text}};
}

// Per-axis statistics of a position's samples (m/s^2; trend = drift over the dwell).
struct SampleStats {
  std::array<double, 3> mean_mps2{};
  std::array<double, 3> sigma_mps2{};
  std::array<double, 3> trend_mps2{};
  double temp_mean_c = kNoValue;
  std::size_t count = 0;
};

SampleStats sample_stats(const std::vector<drivers::AccelSample>& s) {
  SampleStats out;
  out.count = s.size();
  if (s.empty()) return out;
  const double n = static_cast<double>(s.size());
  double t_mean = 0, temp_sum = 0;
  int temp_n = 0;
  for (const auto& x : s) {
    t_mean += x.t_s / n;
    if (std::isfinite(x.temperature_c)) {
      temp_sum += x.temperature_c;
      ++temp_n;
    }
  }
  if (temp_n > 0) out.temp_mean_c = temp_sum / temp_n;
  const double span = s.back().t_s - s.front().t_s;
  for (int a = 0; a < 3; ++a) {
    double mean = 0;
    for (const auto& x : s) mean += x.force_mps2[a] / n;
    double var = 0, stt = 0, sty = 0;
    for (const auto& x : s) {
      const double d = x.force_mps2[a] - mean, dt = x.t_s - t_mean;
      var += d * d;
      stt += dt * dt;
      sty += dt * d;
    }
    out.mean_mps2[a] = mean;
    out.sigma_mps2[a] = s.size() > 1 ? std::sqrt(var / (n - 1)) : 0.0;
    out.trend_mps2[a] = stt > 0 ? sty / stt * span : 0.0;  // least-squares slope x dwell
  }
  return out;
}

std::string axis_name(int a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }

}  // namespace

// --------------------------------------------------------------------------- plumbing

Sequencer::Sequencer(DaemonConfig config, Hardware hardware, RunStore& store, EventFn events)
    : config_(std::move(config)),
      hw_(std::move(hardware)),
      store_(store),
      events_(std::move(events)) {
  if (hw_.time_scale <= 0) hw_.time_scale = 1;
}

Sequencer::~Sequencer() {
  request_shutdown();
  join();
}

void Sequencer::start() {
  thread_ = std::thread([this] { thread_main(); });
}

void Sequencer::join() {
  if (thread_.joinable()) thread_.join();
}

void Sequencer::submit(std::string method, json params, ReplyFn reply, std::string requested_by) {
  {
    std::lock_guard lock(queue_mutex_);
    queue_.push_back(
        Command{std::move(method), std::move(params), std::move(reply), std::move(requested_by)});
  }
  queue_cv_.notify_one();
}

void Sequencer::request_shutdown() {
  {
    std::lock_guard lock(queue_mutex_);
    shutdown_ = true;
  }
  queue_cv_.notify_one();
}

bool Sequencer::executes(const std::string& method) {
  for (const char* name : {m::stand_enable, m::stand_disable, m::stand_home, m::stand_move,
                           m::stand_stop, m::estop, m::estop_reset, m::unit_read, m::run_start,
                           m::run_pause, m::run_resume, m::run_abort, m::operator_confirm}) {
    if (method == name) return true;
  }
  return false;
}

void Sequencer::thread_main() {
  refresh_stand_snapshot();
  for (;;) {
    heartbeat_++;
    std::optional<Command> cmd;
    {
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait_for(lock, std::chrono::duration<double>(kIdleRefreshReal_s),
                         [this] { return shutdown_ || !queue_.empty(); });
      if (!queue_.empty()) {
        cmd = std::move(queue_.front());
        queue_.pop_front();
      } else if (shutdown_) {
        break;
      }
    }
    if (cmd) {
      handle(*cmd);
    } else {
      refresh_stand_snapshot();
    }
  }
  // SIGTERM: leave the stand stopped and without drive power.
  spdlog::info("stopping and disabling the stand axes before exit");
  stop_axes_quietly();
  for (StandAxis a : kAxes) {
    if (hw_.stand->lifecycle() == drivers::Lifecycle::active) (void)hw_.stand->disable(a);
  }
  if (hw_.stand->lifecycle() == drivers::Lifecycle::active) (void)hw_.stand->deactivate();
  // Commands that arrived during shutdown still get an answer.
  std::lock_guard lock(queue_mutex_);
  for (Command& c : queue_)
    c.reply(Outcome{nullptr, static_cast<int>(ErrorCode::busy), "standcald is shutting down"});
  queue_.clear();
}

void Sequencer::raise_interrupt(Interrupt kind) {
  if (static_cast<int>(kind) > static_cast<int>(interrupt_)) interrupt_ = kind;
}

void Sequencer::service() {
  heartbeat_++;
  for (;;) {
    std::optional<Command> cmd;
    {
      std::lock_guard lock(queue_mutex_);
      if (shutdown_) raise_interrupt(Interrupt::shutdown);
      if (queue_.empty()) break;
      cmd = std::move(queue_.front());
      queue_.pop_front();
    }
    handle(*cmd);
  }
  if (interrupt_ != Interrupt::none) {
    const Interrupt kind = interrupt_;
    interrupt_ = Interrupt::none;
    throw Interrupted{kind};
  }
}

void Sequencer::wait_real(double real_s, const std::function<bool()>& until) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(real_s));
  for (;;) {
    service();
    if (until && until()) return;
    std::unique_lock lock(queue_mutex_);
    if (std::chrono::steady_clock::now() >= deadline) return;
    // Wake at the deadline, on a command, or at least once a second for the heartbeat.
    const auto wake = std::min<std::chrono::steady_clock::time_point>(
        deadline, std::chrono::steady_clock::now() + std::chrono::seconds(1));
    queue_cv_.wait_until(lock, wake, [this] { return shutdown_ || !queue_.empty(); });
  }
}

// Commands that act at any time are handled first; the rest need an idle sequencer.
void Sequencer::handle(Command& cmd) {
  const std::string& method = cmd.method;
  try {
    if (handle_at_any_time(cmd)) return;
    if (mode_ != Mode::idle) {
      throw RpcError(ErrorCode::busy,
                     mode_ == Mode::command
                         ? "the stand is busy with " + busy_with_ + "; try again when it is done"
                         : "run " + active_run_id_ + " is in progress; pause or abort it first");
    }
    // Run commands answer once the run is running and then keep the thread for the whole run.
    if (method == m::run_start || method == m::run_resume) {
      json r = method == m::run_start ? start_run(cmd.params) : resume_run(cmd.params);
      auto record = store_.get(r["run_id"].get<std::string>());
      run_loop(*record, [&] { cmd.reply(Outcome{r, 0, {}}); });
      return;
    }
    cmd.reply(Outcome{execute_command(cmd), 0, {}});
  } catch (const RpcError& e) {
    cmd.reply(Outcome{nullptr, e.code(), e.what()});
  } catch (const Interrupted& in) {
    // A stand command cut short by estop / stand.stop / shutdown.
    stop_axes_and_wait();
    mode_ = Mode::idle;
    refresh_stand_snapshot();
    const bool estop = in.kind == Interrupt::estop;
    cmd.reply(Outcome{nullptr,
                      static_cast<int>(estop ? ErrorCode::estop_active : ErrorCode::invalid_state),
                      method + " interrupted by " +
                          (estop                            ? "an emergency stop"
                           : in.kind == Interrupt::shutdown ? "daemon shutdown"
                                                            : "stand.stop")});
    answer_deferred();
  } catch (const std::exception& e) {
    mode_ = Mode::idle;
    cmd.reply(Outcome{nullptr, static_cast<int>(ErrorCode::internal_error), e.what()});
  }
}

// A stand command (not a run): holds the hardware until it answers.
json Sequencer::execute_command(const Command& cmd) {
  busy_with_ = cmd.method;
  mode_ = Mode::command;
  json result;
  try {
    result = execute_idle(cmd);
  } catch (...) {
    mode_ = Mode::idle;
    refresh_stand_snapshot();
    throw;
  }
  mode_ = Mode::idle;
  refresh_stand_snapshot();
  return result;
}

bool Sequencer::handle_at_any_time(Command& cmd) {
  const std::string& method = cmd.method;
  const bool run_held =
      mode_ == Mode::run_active || mode_ == Mode::run_paused || mode_ == Mode::run_waiting_operator;
  if (method == m::estop) {
    emergency_stop(cmd.requested_by);  // at once, whatever else happens; only the answer may wait
    const json result{{"estop", true},
                      {"message", "emergency stop: both axes stopped and disabled"}};
    if (mode_ == Mode::idle) {
      cmd.reply(Outcome{result, 0, {}});
    } else {
      // Answered once the interrupted run is `faulted` (or the command has given up).
      raise_interrupt(Interrupt::estop);
      defer_answer(cmd, result);
    }
  } else if (method == m::stand_stop) {
    stand_stop(cmd);
  } else if (method == m::run_pause || method == m::run_abort || method == m::operator_confirm) {
    if (const auto other = named_other_run(cmd)) {
      throw RpcError(ErrorCode::invalid_state,
                     method + ": run " + *other + " is not the active run" +
                         (active_run_id_.empty() ? " (no run is in progress)"
                                                 : " (" + active_run_id_ + " is)") +
                         "; nothing was changed");
    }
    if (!run_held) throw RpcError(ErrorCode::invalid_state, "no run is in progress");
    act_on_active_run(cmd);
  } else if (method == m::run_resume && run_held) {
    resume_active_run(cmd);
  } else {
    return false;
  }
  return true;
}

std::optional<std::string> Sequencer::named_other_run(const Command& cmd) const {
  protocol::Params p(cmd.params, cmd.method);
  p.only({"run_id"});
  const auto id = p.optional_text("run_id", protocol::text_limit::run_id);
  if (!id || (!active_run_id_.empty() && *id == active_run_id_)) return std::nullopt;
  if (!store_.get(*id))
    throw RpcError(ErrorCode::not_found, cmd.method + ": no run " + *id + " (see runs.list)");
  return id;
}

void Sequencer::act_on_active_run(Command& cmd) {
  if (cmd.method == m::run_pause) {
    if (mode_ == Mode::run_paused)
      throw RpcError(ErrorCode::invalid_state, "the run is already paused");
    raise_interrupt(Interrupt::pause);
    defer_answer(cmd, json{{"run_id", active_run_id_}, {"state", st::paused}});
  } else if (cmd.method == m::run_abort) {
    raise_interrupt(Interrupt::abort);
    defer_answer(cmd, json{{"run_id", active_run_id_}, {"state", st::aborted}});
  } else {
    if (mode_ != Mode::run_waiting_operator) {
      throw RpcError(ErrorCode::invalid_state, "no re-mount step is waiting for the operator");
    }
    operator_confirmed_ = true;
    {
      // Visible at once to run.status, before the run thread moves on.
      std::lock_guard lock(snapshot_mutex_);
      if (progress_.is_object()) progress_["state"] = st::running;
    }
    cmd.reply(Outcome{json{{"run_id", active_run_id_}, {"confirmed", true}}, 0, {}});
  }
}

void Sequencer::resume_active_run(Command& cmd) {
  if (const auto other = named_other_run(cmd)) {
    throw RpcError(ErrorCode::busy, "run.resume: run " + active_run_id_ +
                                        " holds the stand; abort it before resuming " + *other +
                                        " (nothing was changed)");
  }
  if (mode_ != Mode::run_paused) {
    throw RpcError(ErrorCode::invalid_state, "run " + active_run_id_ + " is already running");
  }
  resume_requested_ = true;
  defer_answer(cmd, json{{"run_id", active_run_id_}, {"state", st::running}});
}

// A command or run in progress is interrupted (a run pauses) and the answer waits until
// it has stopped; otherwise the axes are stopped here and the answer waits until they are
// still.
void Sequencer::stand_stop(Command& cmd) {
  protocol::Params(cmd.params, cmd.method).only({});
  if (mode_ == Mode::command || mode_ == Mode::run_active || mode_ == Mode::run_waiting_operator) {
    raise_interrupt(Interrupt::pause);
    defer_answer(cmd, json{{"stopped", true}});
    return;
  }
  if (!stop_axes_and_wait()) {
    throw RpcError(ErrorCode::hardware_fault,
                   "the stand axes were still moving " +
                       std::to_string(int(config_.in_position.timeout_s)) + " s after stand.stop");
  }
  cmd.reply(Outcome{json{{"stopped", true}}, 0, {}});
}

void Sequencer::defer_answer(Command& cmd, json result) {
  deferred_answers_.push_back(DeferredAnswer{std::move(cmd.reply), std::move(result)});
}

void Sequencer::answer_deferred(const std::string& run_state) {
  std::vector<DeferredAnswer> answers;
  answers.swap(deferred_answers_);
  for (DeferredAnswer& a : answers) {
    if (!run_state.empty() && a.result.contains("state")) a.result["state"] = run_state;
    a.reply(Outcome{std::move(a.result), 0, {}});
  }
}

json Sequencer::execute_idle(const Command& cmd) {
  const std::string& method = cmd.method;
  protocol::Params p(cmd.params, method);
  if (method == m::stand_enable) {
    p.only({});
    prepare_stand(false);
    return json{{"enabled", true}};
  }
  if (method == m::stand_disable) {
    p.only({});
    if (hw_.stand->lifecycle() == drivers::Lifecycle::active) {
      for (StandAxis a : kAxes) check(hw_.stand->disable(a));
    }
    return json{{"enabled", false}};
  }
  if (method == m::stand_home) {
    p.only({});
    prepare_stand(false);
    home_axes();
    return json{{"alpha1_deg", read_axis(StandAxis::outer).angle_deg},
                {"alpha2_deg", read_axis(StandAxis::inner).angle_deg}};
  }
  if (method == m::stand_move) {
    p.only({"alpha1_deg", "alpha2_deg", "wait"});
    const double a1 = p.number("alpha1_deg"), a2 = p.number("alpha2_deg");
    const bool wait = p.optional_bool("wait", true);
    if (!std::isfinite(a1) || !std::isfinite(a2))
      throw RpcError(ErrorCode::invalid_params, "stand.move: angles must be finite");
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
    if (!wait) {
      start_move(a1, a2);
      return json{{"accepted", true}};
    }
    auto [r1, r2] = move_and_wait(a1, a2);
    return json{{"alpha1_deg", r1}, {"alpha2_deg", r2}, {"in_position", true}};
  }
  if (method == m::estop_reset) {
    p.only({});
    // The latch is the controller's: an unconfigured stand is configured first so that a
    // latch set before then is found (it puts the stand in error) and reset here.
    if (hw_.stand->lifecycle() == drivers::Lifecycle::unconfigured) check(hw_.stand->configure());
    if (hw_.stand->lifecycle() == drivers::Lifecycle::error) check(hw_.stand->recover());
    estop_latched_ = false;
    return json{{"estop", false},
                {"message", "emergency stop reset: send stand.enable and stand.home"}};
  }
  if (method == m::unit_read) {
    p.only({"seconds"});
    const double seconds = p.number("seconds");
    // Shorter than one sample period reads nothing, and a mean of nothing is not 0.
    const double min_s = 1.0 / config_.sample_rate_hz;
    if (!(seconds >= min_s && seconds <= 3600)) {
      throw RpcError(
          ErrorCode::invalid_params,
          fmt::format(
              "unit.read: \"seconds\" must be between {:g} (one sample at unit.sample_rate_hz "
              "{:g} Hz) and 3600 (got {:g})",
              min_s, config_.sample_rate_hz, seconds));
    }
    return unit_read(seconds);
  }
  throw RpcError(ErrorCode::method_not_found, "unknown method " + method);
}

// --------------------------------------------------------------------------- stand

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
  return {[this] { return stand_time_s(now_real_s()); },
          [this](double stand_s) { wait_real(std::clamp(real_time_s(stand_s), 0.002, 0.05)); }};
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
  const double start = now_real_s();
  const double poll_real = std::clamp(real_time_s(config_.in_position.poll_s), 0.002, 0.05);
  while (!axes_still()) {
    if (stand_time_s(now_real_s() - start) > config_.in_position.timeout_s) {
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
  events_(ev::fault,
          json{{"source", "estop"}, {"message", "emergency stop: both axes stopped and disabled"}});
  if (!s)
    throw RpcError(ErrorCode::hardware_fault,
                   "emergency stop could not be confirmed by the stand: " + s.message);
}

void Sequencer::refresh_stand_snapshot() {
  json axes = json::array();
  for (StandAxis a : kAxes) {
    auto r = hw_.stand->read_state(a);
    axes.push_back(r ? axis_json(a, r.value())
                     : json{{"axis", drivers::to_string(a)}, {"error", r.status().message}});
  }
  const drivers::AccelUnitHealth h = hw_.unit->health();
  json unit{{"name", hw_.unit->name()},
            {"samples", h.samples},
            {"incomplete_samples", h.incomplete_samples},
            {"bus_state", drivers::bus_state_name(h.bus_state)},
            {"silent", h.silent}};
  std::lock_guard lock(snapshot_mutex_);
  stand_snapshot_ = json{{"name", hw_.stand->name()},
                         {"id", config_.stand_id},
                         {"lifecycle", drivers::to_string(hw_.stand->lifecycle())},
                         {"estop_latched", estop_latched_},
                         {"axes", axes},
                         {"unit", unit},
                         {"busy_with", mode_ == Mode::command ? json(busy_with_) : json(nullptr)}};
}

// --------------------------------------------------------------------------- unit

std::vector<drivers::AccelSample> Sequencer::collect(double seconds) {
  std::vector<drivers::AccelSample> all;
  double left = seconds;
  while (left > 1e-9) {
    service();
    const double chunk = std::min(left, kCollectChunk_s);
    auto got = check(hw_.unit->collect(chunk));
    all.insert(all.end(), got.begin(), got.end());
    left -= chunk;
  }
  return all;
}

json Sequencer::unit_read(double seconds) {
  check(hw_.unit->start());
  std::vector<drivers::AccelSample> samples;
  try {
    samples = collect(seconds);
  } catch (...) {
    (void)hw_.unit->stop();
    throw;
  }
  (void)hw_.unit->stop();
  if (samples.empty()) {
    throw RpcError(
        ErrorCode::hardware_fault,
        fmt::format(
            "unit.read: no sample from the accelerometer unit during {:g} s (is it powered and "
            "on the bus?)",
            seconds));
  }
  const SampleStats s = sample_stats(samples);
  json axes = json::object();
  for (int a = 0; a < 3; ++a) {
    axes[axis_name(a)] = json{{"mean_mps2", s.mean_mps2[a]},
                              {"sigma_ug", s.sigma_mps2[a] / config_.g_local_mps2 * 1e6}};
  }
  const drivers::AccelUnitHealth h = hw_.unit->health();
  return json{{"samples", s.count},
              {"rate_hz", seconds > 0 ? s.count / seconds : 0.0},
              {"axes", axes},
              {"temp_c", std::isfinite(s.temp_mean_c) ? json(s.temp_mean_c) : json(nullptr)},
              {"incomplete_samples", h.incomplete_samples}};
}

// --------------------------------------------------------------------------- views

json Sequencer::status() const {
  // Which hardware is live, so nobody mistakes a simulated run for a real one.
  json backend{{"stand", config_.stand_backend},
               {"unit", config_.unit_backend},
               {"simulated", config_.stand_backend == "sim" || config_.unit_backend == "sim"},
               {"description", hw_.description}};
  std::lock_guard lock(snapshot_mutex_);
  return json{{"stand", stand_snapshot_}, {"run", progress_}, {"backend", std::move(backend)}};
}

json Sequencer::run_status(const std::string& run_id) const {
  std::string id = run_id;
  {
    std::lock_guard lock(snapshot_mutex_);
    if (id.empty()) id = active_run_id_;
  }
  if (id.empty()) {
    const auto newest = store_.newest();
    if (!newest) throw RpcError(ErrorCode::not_found, "no run has been started yet");
    id = newest->run_id;
  }
  auto rec = store_.get(id);
  if (!rec) throw RpcError(ErrorCode::not_found, "no run " + id + " (see runs.list)");
  json out{{"run_id", rec->run_id},
           {"state", rec->state},
           {"reason", rec->reason},
           {"unit_serial", rec->unit_serial},
           {"unit_type", rec->unit_type},
           {"program", rec->program_name},
           {"position", rec->positions_done},
           {"positions", rec->positions},
           {"positions_done", rec->positions_done},
           {"phase", nullptr},
           {"eta_s", nullptr},
           {"started_utc", rec->started_utc},
           {"ended_utc", rec->ended_utc},
           {"recording_path", rec->recording_path},
           {"has_result", !rec->result_path.empty()}};
  std::lock_guard lock(snapshot_mutex_);
  if (!progress_.is_null() && progress_.value("run_id", "") == id) {
    for (const char* k : {"state", "position", "phase", "eta_s", "positions_done"})
      out[k] = progress_[k];
  }
  return out;
}

json Sequencer::run_result(const std::string& run_id) const {
  auto rec = store_.get(run_id);
  if (!rec) throw RpcError(ErrorCode::not_found, "no run " + run_id + " (see runs.list)");
  if (rec->result_path.empty()) {
    throw RpcError(ErrorCode::not_found,
                   "run " + run_id + " has no result yet (state " + rec->state + ")");
  }
  std::ifstream in(rec->result_path);
  json doc = json::parse(in, nullptr, false);
  if (!in || doc.is_discarded()) {
    throw RpcError(ErrorCode::internal_error,
                   "the stored result " + rec->result_path + " cannot be read");
  }
  return doc;
}

json Sequencer::runs_list(const RunPageQuery& query) const {
  const RunPage page = store_.page(query);
  json runs = json::array();
  for (const RunSummary& r : page.runs) {
    runs.push_back(json{{"run_id", r.run_id},
                        {"unit_serial", r.unit_serial},
                        {"program", r.program_name},
                        {"state", r.state},
                        {"positions", r.positions},
                        {"positions_done", r.positions_done},
                        {"started_utc", r.started_utc},
                        {"ended_utc", r.ended_utc},
                        {"has_result", r.has_result}});
  }
  json out = json::object();
  out["runs"] = std::move(runs);
  out["more"] = page.more;
  return out;
}

// --------------------------------------------------------------------------- runs

namespace {

StandLimits limits_of(const DaemonConfig& c) {
  StandLimits l;
  l.alpha1 = AxisRange{c.outer.continuous, c.outer.min_deg, c.outer.max_deg};
  l.alpha2 = AxisRange{c.inner.continuous, c.inner.min_deg, c.inner.max_deg};
  return l;
}

}  // namespace

StandLimits Sequencer::stand_limits() const { return limits_of(config_); }

GaussMarkovNoise Sequencer::unit_bias_wander() const {
  return {Vec3::Constant(config_.unit_bias_instability_ug * kUg),
          config_.unit_bias_instability_tau_s};
}

namespace {

bool uses_several_mounts(const Program& p) {
  for (const auto& pos : p.positions) {
    if (pos.mount != p.positions.front().mount) return true;
  }
  return false;
}

RecordingColumns recording_columns(const Program& p) {
  RecordingColumns c;
  c.alpha_measured = true;
  c.temp = true;
  c.mount = uses_several_mounts(p);
  c.t_arrive = true;
  c.approach = true;
  return c;
}

std::string number_text(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

Program program_from_params(const json& spec, const DaemonConfig& config) {
  try {
    if (spec.is_string()) {
      const std::string name = spec.get<std::string>();
      protocol::require_text_field("run.start: parameter \"program\"", name,
                                   protocol::text_limit::program_name);
      if (name == "paper9" || name == "classic24") return load_program(name);
      // A NUL would end the file name early at the system call.
      if (name.empty() || name.find_first_of(std::string("/\0", 2)) != std::string::npos ||
          name[0] == '.') {
        throw RpcError(ErrorCode::invalid_params,
                       "run.start: programme name \"" + name +
                           "\" is not a library name (no paths; inline positions are allowed)");
      }
      const std::string path = config.program_library_dir + "/" + name + ".json";
      if (config.program_library_dir.empty() || !std::filesystem::exists(path)) {
        throw RpcError(
            ErrorCode::not_found,
            "no programme \"" + name + "\": not paper9, classic24 or in the library" +
                (config.program_library_dir.empty() ? std::string(" (no library configured)")
                                                    : " " + config.program_library_dir));
      }
      return load_program(path);
    }
    if (spec.is_array())
      return program_from_json(json{{"name", "inline"}, {"positions", spec}}, "run.start program");
    if (spec.is_object()) {
      json doc = spec;
      if (!doc.contains("name")) doc["name"] = "inline";
      return program_from_json(doc, "run.start program");
    }
  } catch (const ProgramError& e) {
    throw RpcError(ErrorCode::invalid_params, e.what());
  }
  throw RpcError(ErrorCode::invalid_params,
                 "run.start: \"program\" must be a name or inline positions [{\"alpha1_deg\", "
                 "\"alpha2_deg\"}, ...]");
}

}  // namespace

json Sequencer::start_run(const json& params) {
  protocol::Params p(params, m::run_start);
  p.only({"program", "dwell_s", "settle_s", "unit_serial", "unit_type", "operator"});
  // Text fields go into the recording header, run.json and the records database: each
  // one line of printable text, counted in characters (protocol/jsonrpc/text.hpp).
  namespace limit = protocol::text_limit;
  const std::string serial = p.optional_text("unit_serial", limit::unit_serial).value_or("");
  if (serial.empty()) {
    throw RpcError(ErrorCode::invalid_params,
                   "run.start: parameter \"unit_serial\" is required (1 to 64 characters)");
  }
  const std::string unit_type = p.optional_text("unit_type", limit::unit_type).value_or("");
  const std::string operator_name = p.optional_text("operator", limit::operator_name).value_or("");
  const json* spec = p.find("program");
  if (spec == nullptr)
    throw RpcError(ErrorCode::invalid_params, "run.start: parameter \"program\" is required");
  Program program = program_from_params(*spec, config_);
  protocol::require_text_field("run.start: the programme's \"name\"", program.name,
                               limit::program_name);
  try {
    program = normalise_program(program, limits_of(config_));
  } catch (const ProgramError& e) {
    throw RpcError(ErrorCode::limit, e.what());
  }
  const double dwell = p.optional_number("dwell_s").value_or(config_.dwell_s);
  const double settle = p.optional_number("settle_s").value_or(config_.settle_s);
  if (!(dwell > 0 && dwell <= kMaxDwell_s))
    throw RpcError(ErrorCode::invalid_params, "run.start: \"dwell_s\" must be in (0, 36000]");
  if (!(settle >= 0 && settle <= kMaxSettle_s))
    throw RpcError(ErrorCode::invalid_params, "run.start: \"settle_s\" must be in [0, 3600]");
  if (estop_latched_)
    throw RpcError(ErrorCode::estop_active, "emergency stop is latched: send estop.reset first");

  RunRecord r;
  r.run_id = store_.new_run_id(serial);
  r.unit_serial = serial;
  r.unit_type = unit_type;
  r.program_name = program.name;
  r.program = program_to_json(program);
  r.dwell_s = dwell;
  r.settle_s = settle;
  r.operator_name = operator_name;
  r.state = st::running;
  r.positions = static_cast<int>(program.positions.size());
  r.started_utc = utc_now_iso();
  r.recording_path = store_.run_dir(r.run_id) + "/recording.csv";
  r.stand_id = config_.stand_id;
  r.config_hash = config_hash(config_);
  r.software_version = kVersion;
  r.g_source = config_.g_source;
  r.g_local_mps2 = config_.g_local_mps2;
  store_.save(r);
  spdlog::info("run {} started: programme {} ({} positions), unit {}", r.run_id,
               protocol::printable(r.program_name), r.positions, protocol::printable(serial));
  return json{
      {"run_id", r.run_id}, {"positions", r.positions}, {"recording_path", r.recording_path}};
}

json Sequencer::resume_run(const json& params) {
  protocol::Params p(params, m::run_resume);
  p.only({"run_id"});
  std::optional<RunRecord> rec;
  if (auto id = p.optional_text("run_id", protocol::text_limit::run_id)) {
    rec = store_.get(*id);
    if (!rec) throw RpcError(ErrorCode::not_found, "no run " + *id + " (see runs.list)");
  } else {
    rec = store_.latest_resumable();
    if (!rec)
      throw RpcError(ErrorCode::not_found, "no interrupted, faulted or paused run to resume");
  }
  if (rec->state != st::interrupted && rec->state != st::faulted && rec->state != st::paused) {
    throw RpcError(ErrorCode::invalid_state,
                   "run " + rec->run_id + " is " + rec->state + " and cannot be resumed");
  }
  if (estop_latched_)
    throw RpcError(ErrorCode::estop_active, "emergency stop is latched: send estop.reset first");
  try {
    // A run stored before the programme rules tightened (e.g. a dwell past the run limit)
    // is refused here, not by run_loop, which has already taken the stand.
    (void)program_from_json(rec->program, rec->run_id);
  } catch (const ProgramError& e) {
    throw RpcError(ErrorCode::invalid_state,
                   "run " + rec->run_id + " cannot be resumed: " + e.what());
  }
  spdlog::info("run {} resumed at position {}/{}", rec->run_id, rec->positions_done + 1,
               rec->positions);
  return json{{"run_id", rec->run_id},
              {"position", rec->positions_done + 1},
              {"positions", rec->positions}};
}

double Sequencer::run_clock_s() const {
  return run_clock_base_s_ + stand_time_s(now_real_s() - run_clock_start_real_s_);
}

void Sequencer::set_state(RunRecord& record, const std::string& state, const std::string& reason) {
  record.state = state;
  record.reason = reason;
  if (state == st::done || state == st::aborted || state == st::faulted ||
      state == st::interrupted) {
    record.ended_utc = utc_now_iso();
  }
  try {
    store_.save(record);  // the in-memory state is updated even when the file cannot be
  } catch (const std::exception& e) {
    // Disk full: run.status still answers from memory; after a restart the run is
    // `interrupted` (the last state on disk was an active one) and resumable.
    spdlog::error("run {}: cannot store the state {}: {}", record.run_id, state, e.what());
  }
  {
    std::lock_guard lock(snapshot_mutex_);
    if (progress_.is_object()) progress_["state"] = state;
  }
  // The one log line of a state change; a fault is logged here once, at error level.
  const auto level = state == st::faulted ? spdlog::level::err : spdlog::level::info;
  if (reason.empty()) {
    spdlog::log(level, "run {}: {}", record.run_id, state);
  } else {
    spdlog::log(level, "run {}: {} ({})", record.run_id, state, reason);
  }
  events_(ev::run_state, json{{"run_id", record.run_id},
                              {"state", state},
                              {"reason", reason},
                              {"positions_done", record.positions_done},
                              {"positions", record.positions}});
}

void Sequencer::set_progress(const RunRecord& record, int index, const std::string& phase) {
  const int remaining = std::max(0, record.positions - index);
  const double per_position_real_s =
      positions_timed_ > 0
          ? mean_position_real_s_
          : real_time_s(record.dwell_s + record.settle_s + 10.0);  // 10 s: a typical move
  json progress{{"run_id", record.run_id},
                {"state", record.state},
                {"position", std::min(index + 1, record.positions)},
                {"positions", record.positions},
                {"positions_done", record.positions_done},
                {"phase", phase},
                {"eta_s", remaining * per_position_real_s}};
  {
    std::lock_guard lock(snapshot_mutex_);
    progress_ = progress;
  }
  events_(ev::run_progress, progress);
}

void Sequencer::run_loop(RunRecord record, const std::function<void()>& started) {
  mode_ = Mode::run_active;
  interrupt_ = Interrupt::none;
  {
    std::lock_guard lock(snapshot_mutex_);
    active_run_id_ = record.run_id;
  }
  const Program program = program_from_json(record.program, record.run_id);
  if (record.recording_bytes > 0) {
    if (const std::string note = fit_record_to_recording(record); !note.empty()) {
      spdlog::warn("run {}: {}", record.run_id, note);
      events_(ev::fault, json{{"run_id", record.run_id}, {"message", note}});
    }
  }
  const bool fresh = record.recording_bytes == 0;
  run_clock_base_s_ =
      fresh ? 0.0 : record.last_t_s + 1.0;  // resumed: time continues after the last row
  run_clock_start_real_s_ = now_real_s();
  last_t_s_ = record.last_t_s;
  positions_timed_ = 0;
  mean_position_real_s_ = 0;
  mounted_ = (!fresh && uses_several_mounts(program))
                 ? std::nullopt
                 : std::optional<Mount>(program.positions.front().mount);
  if (fresh && hw_.simulated_remount) hw_.simulated_remount(program.positions.front().mount);
  set_state(record, st::running);
  started();

  std::optional<RecordingFile> file;
  int index = record.positions_done;
  bool finished = false;
  try {
    for (;;) {
      try {
        if (!file) {
          set_progress(record, index, "preparing");
          prepare_stand(true);
          last_cmd_deg_ = {read_axis(StandAxis::outer).angle_deg,
                           read_axis(StandAxis::inner).angle_deg};
          if (fresh) {
            Recording header;
            header.set_header("g_local_mps2", number_text(record.g_local_mps2));
            header.set_header("settle_s", number_text(record.settle_s));
            header.set_header("sample_rate_hz", number_text(config_.sample_rate_hz));
            header.set_header("unit_serial", record.unit_serial);
            if (!record.unit_type.empty()) header.set_header("unit_type", record.unit_type);
            header.set_header("program", record.program_name);
            header.set_header("started_utc", record.started_utc);
            header.set_header("run_id", record.run_id);
            header.set_header("stand_id", record.stand_id);
            header.columns = recording_columns(program);
            file.emplace(
                RecordingFile::create(record.recording_path, format_recording_header(header)));
            record.recording_bytes = file->length();
            record.header_bytes = file->length();
            record.position_end_bytes.clear();
            store_.save(record);
          } else {
            file.emplace(RecordingFile::reopen(record.recording_path, record.recording_bytes));
          }
          if (config_.thermal.enabled && record.positions_done == 0) wait_thermal_stability(record);
        }
        if (index >= record.positions) break;
        measure_position(record, program, index, *file);
        ++index;
      } catch (const Interrupted& in) {
        stop_axes_and_wait();  // before the state changes: its answer says the stand stopped
        if (in.kind == Interrupt::pause) {
          if (wait_while_paused(record)) continue;
        } else {
          finish_interrupted(record, in.kind);
        }
        finished = true;
        break;
      }
    }
    if (!finished) finish_with_fit(record);
  } catch (const std::exception& e) {
    stop_axes_quietly();
    if (hw_.unit) (void)hw_.unit->stop();
    events_(ev::fault, json{{"run_id", record.run_id}, {"message", e.what()}});
    set_state(record, st::faulted, e.what());
  }
  mode_ = Mode::idle;
  {
    std::lock_guard lock(snapshot_mutex_);
    active_run_id_.clear();
    progress_ = nullptr;
  }
  refresh_stand_snapshot();
  // Once status shows no active run: an abort's answer, or a pause that came while the
  // run was fitting (the answer then says `done`).
  answer_deferred(record.state);
}

bool Sequencer::wait_while_paused(RunRecord& record) {
  mode_ = Mode::run_paused;
  resume_requested_ = false;
  set_state(record, st::paused,
            "paused by the operator; run.resume continues with the current position");
  set_progress(record, record.positions_done, "paused");
  answer_deferred(st::paused);
  for (;;) {
    try {
      wait_real(1.0, [this] { return resume_requested_; });
    } catch (const Interrupted& in) {
      if (in.kind == Interrupt::pause) continue;
      mode_ = Mode::run_active;
      finish_interrupted(record, in.kind);
      return false;
    }
    if (resume_requested_) {
      mode_ = Mode::run_active;
      set_state(record, st::running);
      answer_deferred(st::running);
      return true;
    }
  }
}

void Sequencer::finish_interrupted(RunRecord& record, Interrupt kind) {
  if (hw_.unit) (void)hw_.unit->stop();
  switch (kind) {
    case Interrupt::abort:
      set_state(record, st::aborted, "aborted by the operator; the recorded positions are kept");
      break;
    case Interrupt::estop:
      set_state(record, st::faulted,
                "emergency stop; estop.reset, then run.resume continues the run");
      break;
    default:
      set_state(record, st::interrupted,
                "standcald was stopped during the run; run.resume continues it");
      break;
  }
}

void Sequencer::wait_for_operator(RunRecord& record, const Program& program, int index) {
  const Mount mount = program.positions[static_cast<std::size_t>(index)].mount;
  mode_ = Mode::run_waiting_operator;
  operator_confirmed_ = false;
  set_state(record, st::waiting_operator,
            "re-mount the unit for mount " + mount_name(mount) + " (position " +
                std::to_string(index + 1) + "), then send operator.confirm");
  set_progress(record, index, "waiting_operator");
  try {
    while (!operator_confirmed_) wait_real(1.0, [this] { return operator_confirmed_; });
  } catch (...) {
    mode_ = Mode::run_active;
    throw;
  }
  mode_ = Mode::run_active;
  if (hw_.simulated_remount) hw_.simulated_remount(mount);
  mounted_ = mount;
  set_state(record, st::running);
}

void Sequencer::wait_thermal_stability(RunRecord& record) {
  const ThermalWait& tw = config_.thermal;
  set_progress(record, 0, "thermal_wait");
  const double start = run_clock_s();
  for (;;) {
    check(hw_.unit->start());
    const std::vector<drivers::AccelSample> s = collect(tw.window_s);
    (void)hw_.unit->stop();
    double n = 0, t_mean = 0, c_mean = 0;
    for (const auto& x : s) {
      if (!std::isfinite(x.temperature_c)) continue;
      n += 1;
      t_mean += x.t_s;
      c_mean += x.temperature_c;
    }
    if (n < 2)
      throw RpcError(ErrorCode::hardware_fault,
                     "thermal wait is configured but the unit reports no temperature");
    t_mean /= n;
    c_mean /= n;
    double stt = 0, stc = 0;
    for (const auto& x : s) {
      if (!std::isfinite(x.temperature_c)) continue;
      stt += (x.t_s - t_mean) * (x.t_s - t_mean);
      stc += (x.t_s - t_mean) * (x.temperature_c - c_mean);
    }
    const double rate_c_per_min = stt > 0 ? stc / stt * 60.0 : 0.0;
    if (std::abs(rate_c_per_min) < tw.rate_limit_c_per_min) return;
    if (run_clock_s() - start > tw.timeout_s) {
      throw RpcError(ErrorCode::hardware_fault,
                     "the unit temperature still changes by " + number_text(rate_c_per_min) +
                         " °C/min after the thermal wait's " + number_text(tw.timeout_s) + " s");
    }
  }
}

void Sequencer::measure_position(RunRecord& record, const Program& program, int index,
                                 RecordingFile& file) {
  const ProgramPosition& pp = program.positions[static_cast<std::size_t>(index)];
  const double started_real = now_real_s();
  if (!mounted_ || *mounted_ != pp.mount) wait_for_operator(record, program, index);

  set_progress(record, index, "moving");
  if (hw_.stand->lifecycle() != drivers::Lifecycle::active) {
    // The driver dropped to `error` (link lost after its retries) while the unit sampled.
    throw RpcError(ErrorCode::hardware_fault, "lost the link to the stand " + hw_.stand->name() +
                                                  " during the run (" +
                                                  drivers::to_string(hw_.stand->lifecycle()) +
                                                  "); run.resume reconnects and continues");
  }
  const auto [a1, a2] = move_and_wait(pp.alpha1_deg, pp.alpha2_deg);
  const double t_arrive = std::max(run_clock_s(), last_t_s_);
  const int approach = approach_directions({last_cmd_deg_, {pp.alpha1_deg, pp.alpha2_deg}})[1];
  last_cmd_deg_ = {pp.alpha1_deg, pp.alpha2_deg};
  events_(ev::position_reached, json{{"run_id", record.run_id},
                                     {"position", index + 1},
                                     {"pos", index},
                                     {"alpha1_cmd_deg", pp.alpha1_deg},
                                     {"alpha2_cmd_deg", pp.alpha2_deg},
                                     {"alpha1_deg", a1},
                                     {"alpha2_deg", a2},
                                     {"t_arrive_s", t_arrive}});

  const double settle = pp.settle_s.value_or(record.settle_s);
  const double dwell = pp.dwell_s.value_or(record.dwell_s);
  set_progress(record, index, "settling");
  wait_real(real_time_s(settle));

  std::vector<drivers::AccelSample> samples;
  SampleStats stats;
  double t_first = 0;
  for (int attempt = 0;; ++attempt) {
    set_progress(record, index, attempt == 0 ? "sampling" : "re-measuring");
    const std::uint64_t incomplete_before = hw_.unit->health().incomplete_samples;
    t_first = std::max(run_clock_s(), last_t_s_ + 1e-3);
    check(hw_.unit->start());
    try {
      samples = collect(dwell);
    } catch (...) {
      (void)hw_.unit->stop();
      throw;
    }
    (void)hw_.unit->stop();
    stats = sample_stats(samples);
    const double g = record.g_local_mps2;
    std::string problem;
    const double expected = dwell * config_.sample_rate_hz;
    const std::uint64_t incomplete = hw_.unit->health().incomplete_samples - incomplete_before;
    if (samples.empty() && incomplete == 0) {
      // A dwell shorter than the unit's silence timeout ends before the driver calls the
      // unit silent: say what the operator should check.
      problem = "no sample from the accelerometer unit " + hw_.unit->name() + " during the " +
                number_text(dwell) + " s dwell (is it powered and on the bus?)";
    } else if (samples.size() < 2 || static_cast<double>(samples.size()) <
                                         config_.stability.min_sample_fraction * expected) {
      problem = "only " + std::to_string(samples.size()) + " of " +
                std::to_string(static_cast<long>(expected)) + " expected samples (" +
                std::to_string(incomplete) + " incomplete)";
    }
    for (int a = 0; a < 3 && problem.empty(); ++a) {
      const double sigma_ug = stats.sigma_mps2[a] / g * 1e6,
                   trend_ug = stats.trend_mps2[a] / g * 1e6;
      if (sigma_ug > config_.stability.sigma_limit_ug) {
        problem = "axis " + axis_name(a) + " noise " + number_text(sigma_ug) +
                  " µg above the limit " + number_text(config_.stability.sigma_limit_ug) + " µg";
      } else if (std::abs(trend_ug) > config_.stability.trend_limit_ug) {
        problem = "axis " + axis_name(a) + " drifted " + number_text(trend_ug) +
                  " µg during the dwell (limit " + number_text(config_.stability.trend_limit_ug) +
                  " µg)";
      }
    }
    if (problem.empty()) break;
    if (attempt >= config_.stability.remeasure_max) {
      throw RpcError(ErrorCode::hardware_fault,
                     "position " + std::to_string(index + 1) + " not stable after " +
                         std::to_string(attempt + 1) + " measurements: " + problem);
    }
    spdlog::warn("run {}: re-measuring position {}: {}", record.run_id, index + 1, problem);
    events_(ev::fault, json{{"run_id", record.run_id},
                            {"position", index + 1},
                            {"message", "re-measuring position " + std::to_string(index + 1) +
                                            ": " + problem}});
  }

  // Rows on the run clock: the unit's own sample spacing, starting when sampling began.
  const RecordingColumns columns = recording_columns(program);
  std::vector<RecordingSample> rows;
  rows.reserve(samples.size());
  const double t0_unit = samples.front().t_s;
  for (const drivers::AccelSample& x : samples) {
    RecordingSample r;
    r.t_s = t_first + (x.t_s - t0_unit);
    r.pos = index;
    r.alpha1_cmd_deg = pp.alpha1_deg;
    r.alpha2_cmd_deg = pp.alpha2_deg;
    r.alpha1_deg = a1;
    r.alpha2_deg = a2;
    r.f_mps2 = Vec3(x.force_mps2[0], x.force_mps2[1], x.force_mps2[2]);
    r.temp_c = std::isfinite(x.temperature_c) ? x.temperature_c : kNoValue;
    if (columns.mount) r.mount = pp.mount;
    r.t_arrive_s = t_arrive;
    r.approach = static_cast<std::int8_t>(approach);
    rows.push_back(r);
  }
  std::string text;
  text.reserve(rows.size() * 120);
  append_recording_rows(text, columns, rows);
  record.recording_bytes = file.append_durably(text);
  record.position_end_bytes.resize(static_cast<std::size_t>(index));
  record.position_end_bytes.push_back(record.recording_bytes);
  record.positions_done = index + 1;
  record.last_t_s = rows.back().t_s;
  last_t_s_ = record.last_t_s;
  store_.save(record);  // only now is the position done: a crash before this re-measures it

  json mean = json::array(), sigma = json::array(), trend = json::array();
  for (int a = 0; a < 3; ++a) {
    mean.push_back(stats.mean_mps2[a]);
    sigma.push_back(stats.sigma_mps2[a] / record.g_local_mps2 * 1e6);
    trend.push_back(stats.trend_mps2[a] / record.g_local_mps2 * 1e6);
  }
  events_(
      ev::position_averaged,
      json{{"run_id", record.run_id},
           {"position", index + 1},
           {"pos", index},
           {"samples", samples.size()},
           {"mean_mps2", mean},
           {"sigma_ug", sigma},
           {"trend_ug", trend},
           {"temp_c", std::isfinite(stats.temp_mean_c) ? json(stats.temp_mean_c) : json(nullptr)}});
  const double took = now_real_s() - started_real;
  mean_position_real_s_ =
      (mean_position_real_s_ * positions_timed_ + took) / (positions_timed_ + 1);
  ++positions_timed_;
  set_progress(record, index + 1, "moving");
}

namespace {

// The paper's joint fit of a finished run. A programme that cannot determine the unit by
// itself (a follow-up of proposed positions, a user programme of a few poses) still ends
// `done`: its recording is whole, and the result says why there are no parameters (and
// there is no compensation).
struct JointFit {
  json result;
  std::optional<FitResult> fit;
};

JointFit joint_fit(const std::vector<PositionAverage>& averages, const FitNoiseOptions& noise,
                   const std::optional<AllanFinding>& allan) {
  try {
    FitResult fit = fit_invariant_joint(averages, noise);
    fit.noise.allan = allan;
    return {fit_to_json(fit), std::move(fit)};
  } catch (const CannotFit& e) {
    return {json{{"estimator", "joint"},
                 {"positions", averages.size()},
                 {"parameters", json::object()},
                 {"fit_error", e.what()}},
            std::nullopt};
  }
}

// The GUM budget of the run's joint fit with the configured inputs (run.budget). A budget
// that cannot be evaluated says why in the result; the run is done all the same.
json run_budget(const FitResult& fit, const RunRecord& record,
                const std::vector<PositionAverage>& averages, const BudgetConfig& config) {
  try {
    return budget_to_json(evaluate_budget(averages, fit, budget_estimator("joint", fit), config,
                                          record.unit_type, record.g_local_mps2));
  } catch (const std::exception& e) {
    return json{{"error", e.what()}};
  }
}

// The compensation of the run's joint fit, with the run's identity: what an INS loads.
Compensation run_compensation(const FitResult& fit, const RunRecord& record,
                              const std::vector<PositionAverage>& averages) {
  Compensation c = make_compensation(fit, record.g_local_mps2);
  c.identity = compensation_identity(
      RunIdentity{record.unit_serial, record.unit_type, record.run_id, record.stand_id,
                  record.ended_utc, record.recording_path, record.g_source},
      averages);
  stamp_written(c);
  return c;
}

}  // namespace

void Sequencer::finish_with_fit(RunRecord& record) {
  set_progress(record, record.positions, "fitting");
  // Streamed: the daemon holds one dwell of the recording, not the whole run.
  const RecordingDigest digest = digest_recording(record.recording_path);
  const std::vector<PositionAverage>& averages = digest.averages;
  // The noise model of both fits: wander between dwells from the fit, Allan within them.
  const std::optional<AllanFinding> allan = digest.allan_finding();
  FitNoiseOptions noise;
  noise.specified = unit_bias_wander();
  JointFit joint = joint_fit(averages, noise, allan);
  json& result = joint.result;
  try {
    FullFitOptions full_options;
    full_options.noise = noise;
    FitResult full = fit_full_vector(averages, full_options);
    full.noise.allan = allan;
    result["full_vector"] = fit_to_json(full);
  } catch (const std::exception& e) {
    result["full_vector"] = json{{"error", e.what()}};
  }
  record.ended_utc = utc_now_iso();
  result["recording_path"] = record.recording_path;
  result["traceability"] =
      json{{"run_id", record.run_id},           {"unit_serial", record.unit_serial},
           {"unit_type", record.unit_type},     {"stand_id", record.stand_id},
           {"program", record.program_name},    {"g_local_mps2", record.g_local_mps2},
           {"g_source", record.g_source},       {"software_version", record.software_version},
           {"config_hash", record.config_hash}, {"operator", record.operator_name},
           {"started_utc", record.started_utc}, {"ended_utc", record.ended_utc}};
  result["recording_warnings"] = digest.recording.warnings;
  const std::string dir = store_.run_dir(record.run_id);
  if (joint.fit && config_.budget)
    result["uncertainty_budget"] = run_budget(*joint.fit, record, averages, *config_.budget);
  if (joint.fit) {
    // The files first: a result that names a compensation has it on disk.
    const Compensation c = run_compensation(*joint.fit, record, averages);
    write_compensation(c, dir + "/compensation", 0640);
    result["compensation"] = compensation_to_json(c);
  }
  const std::string path = dir + "/result.json";
  write_state_file(path, result.dump(2) + "\n");
  record.result_path = path;
  set_state(record, st::done);
}

}  // namespace standcal::daemon
