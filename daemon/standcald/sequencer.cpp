#include "daemon/standcald/sequencer.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <stdexcept>

#include "daemon/standcald/sequencer_detail.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"

// The sequencer's command queue and thread: how commands arrive, which ones act at once
// while a run holds the stand, how waits keep serving them, deferred answers, and the
// thread-safe views. Stand and unit commands are in sequencer_stand.cpp, runs in
// sequencer_run.cpp.
namespace standcal::daemon {

// The sequencer files' shared names: sequencer_detail.hpp.
using namespace detail;

namespace {
constexpr double kIdleRefreshReal_s = 1.0;  // idle: stand snapshot and heartbeat once a second
}  // namespace

// --------------------------------------------------------------------------- plumbing

Sequencer::Sequencer(DaemonConfig config, Hardware hardware, RunStore& store, EventFn events)
    : config_(std::move(config)),
      hw_(std::move(hardware)),
      store_(store),
      events_(std::move(events)) {
  // Hardware's members default to the steady clock and no re-mount; emptied, they are a
  // caller's mistake, said here rather than as a crash at the first settle.
  if (!hw_.clock || !hw_.remount)
    throw std::invalid_argument("Sequencer: the hardware's clock and remount must be set");
}

Sequencer::~Sequencer() {
  request_shutdown();
  join();
}

void Sequencer::start() {
  // Before the thread: a status answered the moment the server runs must already show the
  // stand (it had said lifecycle "" and no axes until the thread's first refresh).
  refresh_stand_snapshot();
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

// Every method the sequencer answers, with when and how (method_table.hpp says who may
// call it and routes it here): at any time, even while a run holds the stand (the handler
// answers, or defers its answer, and returns true; false hands the command on); as a
// stand command that holds the stand until it answers; or as a run that answers once
// running and keeps the thread until the run ends.
const Sequencer::Binding Sequencer::kBindings[] = {
    {m::estop, &Sequencer::estop_at_any_time, nullptr, nullptr},
    {m::stand_stop, &Sequencer::stand_stop, nullptr, nullptr},
    {m::run_pause, &Sequencer::act_on_active_run, nullptr, nullptr},
    {m::run_abort, &Sequencer::act_on_active_run, nullptr, nullptr},
    {m::operator_confirm, &Sequencer::act_on_active_run, nullptr, nullptr},
    {m::run_resume, &Sequencer::resume_active_run, nullptr, &Sequencer::resume_run},
    {m::run_start, nullptr, nullptr, &Sequencer::start_run},
    {m::stand_enable, nullptr, &Sequencer::enable_stand, nullptr},
    {m::stand_disable, nullptr, &Sequencer::disable_stand, nullptr},
    {m::stand_home, nullptr, &Sequencer::home_stand, nullptr},
    {m::stand_move, nullptr, &Sequencer::move_stand, nullptr},
    {m::estop_reset, nullptr, &Sequencer::reset_estop, nullptr},
    {m::unit_read, nullptr, &Sequencer::read_unit, nullptr},
};

const Sequencer::Binding* Sequencer::binding(std::string_view method) {
  for (const Binding& b : kBindings) {
    if (b.method == method) return &b;
  }
  return nullptr;
}

bool Sequencer::handles(std::string_view method) { return binding(method) != nullptr; }

std::vector<std::string_view> Sequencer::handled_methods() {
  std::vector<std::string_view> names;
  for (const Binding& b : kBindings) names.push_back(b.method);
  return names;
}

void Sequencer::thread_main() {
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
    const Binding* b = binding(method);
    if (b == nullptr) throw RpcError(ErrorCode::method_not_found, "unknown method " + method);
    if (b->at_any_time != nullptr && (this->*b->at_any_time)(cmd)) return;
    if (mode_ != Mode::idle) {
      throw RpcError(ErrorCode::busy,
                     mode_ == Mode::command
                         ? "the stand is busy with " + busy_with_ + "; try again when it is done"
                         : "run " + active_run_id_ + " is in progress; pause or abort it first");
    }
    // Run commands answer once the run is running and then keep the thread for the whole run.
    if (b->run != nullptr) {
      const json r = (this->*b->run)(cmd.params);
      auto record = store_.get(r["run_id"].get<std::string>());
      run_loop(*record, [&] { cmd.reply(Outcome{r, 0, {}}); });
      return;
    }
    cmd.reply(Outcome{execute_command(cmd, b->command), 0, {}});
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
json Sequencer::execute_command(const Command& cmd, CommandHandler handler) {
  busy_with_ = cmd.method;
  mode_ = Mode::command;
  json result;
  try {
    result = (this->*handler)(cmd);
  } catch (...) {
    mode_ = Mode::idle;
    refresh_stand_snapshot();
    throw;
  }
  mode_ = Mode::idle;
  refresh_stand_snapshot();
  return result;
}

bool Sequencer::run_held() const {
  return mode_ == Mode::run_active || mode_ == Mode::run_paused ||
         mode_ == Mode::run_waiting_operator;
}

bool Sequencer::estop_at_any_time(Command& cmd) {
  emergency_stop(cmd.requested_by);  // at once, whatever else happens; only the answer may wait
  const json result{{"estop", true}, {"message", "emergency stop: both axes stopped and disabled"}};
  if (mode_ == Mode::idle) {
    cmd.reply(Outcome{result, 0, {}});
  } else {
    // Answered once the interrupted run is `faulted` (or the command has given up).
    raise_interrupt(Interrupt::estop);
    defer_answer(cmd, result);
  }
  return true;
}

std::optional<std::string> Sequencer::named_other_run(const Command& cmd) const {
  const auto id = protocol::RunTargetParams::parse(cmd.params, cmd.method).run_id;
  if (!id || (!active_run_id_.empty() && *id == active_run_id_)) return std::nullopt;
  if (!store_.get(*id))
    throw RpcError(ErrorCode::not_found, cmd.method + ": no run " + *id + " (see runs.list)");
  return id;
}

// run.pause, run.abort and operator.confirm act on the active run, and only on it: acting
// on it when the request named another would pause, abort or confirm a run the operator
// did not mean.
bool Sequencer::act_on_active_run(Command& cmd) {
  if (const auto other = named_other_run(cmd)) {
    throw RpcError(
        ErrorCode::invalid_state,
        cmd.method + ": run " + *other + " is not the active run" +
            (active_run_id_.empty() ? " (no run is in progress)" : " (" + active_run_id_ + " is)") +
            "; nothing was changed");
  }
  if (!run_held()) throw RpcError(ErrorCode::invalid_state, "no run is in progress");
  if (cmd.method == m::run_pause) {
    if (mode_ == Mode::run_paused)
      throw RpcError(ErrorCode::invalid_state, "the run is already paused");
    raise_interrupt(Interrupt::pause);
    defer_answer(cmd, protocol::RunStateResult{active_run_id_, st::paused});
  } else if (cmd.method == m::run_abort) {
    raise_interrupt(Interrupt::abort);
    defer_answer(cmd, protocol::RunStateResult{active_run_id_, st::aborted});
  } else {
    if (mode_ != Mode::run_waiting_operator) {
      throw RpcError(ErrorCode::invalid_state, "no re-mount step is waiting for the operator");
    }
    operator_confirmed_ = true;
    {
      // Visible at once to run.status, before the run thread moves on.
      std::lock_guard lock(snapshot_mutex_);
      if (progress_) progress_->state = st::running;
    }
    cmd.reply(Outcome{protocol::ConfirmedResult{active_run_id_, true}, 0, {}});
  }
  return true;
}

// run.resume while a run holds the stand resumes that run when paused; with no run held
// it resumes a stored run (resume_run, like run.start).
bool Sequencer::resume_active_run(Command& cmd) {
  if (!run_held()) return false;
  if (const auto other = named_other_run(cmd)) {
    throw RpcError(ErrorCode::busy, "run.resume: run " + active_run_id_ +
                                        " holds the stand; abort it before resuming " + *other +
                                        " (nothing was changed)");
  }
  if (mode_ != Mode::run_paused) {
    throw RpcError(ErrorCode::invalid_state, "run " + active_run_id_ + " is already running");
  }
  resume_requested_ = true;
  defer_answer(cmd, protocol::RunStateResult{active_run_id_, st::running});
  return true;
}

// A command or run in progress is interrupted (a run pauses) and the answer waits until
// it has stopped; otherwise the axes are stopped here and the answer waits until they are
// still.
bool Sequencer::stand_stop(Command& cmd) {
  protocol::parse_no_params(cmd.params, cmd.method);
  if (mode_ == Mode::command || mode_ == Mode::run_active || mode_ == Mode::run_waiting_operator) {
    raise_interrupt(Interrupt::pause);
    defer_answer(cmd, protocol::StoppedResult{});
    return true;
  }
  if (!stop_axes_and_wait()) {
    throw RpcError(ErrorCode::hardware_fault,
                   "the stand axes were still moving " +
                       std::to_string(int(config_.in_position.timeout_s)) + " s after stand.stop");
  }
  cmd.reply(Outcome{protocol::StoppedResult{}, 0, {}});
  return true;
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

// --------------------------------------------------------------------------- views

protocol::StatusResult Sequencer::status() const {
  protocol::StatusResult s;
  // Which hardware is live, so nobody mistakes a simulated run for a real one.
  s.backend = {config_.stand_backend, config_.unit_backend,
               config_.stand_backend == "sim" || config_.unit_backend == "sim", hw_.description};
  std::lock_guard lock(snapshot_mutex_);
  s.stand = stand_snapshot_;
  s.run = progress_;
  return s;
}

protocol::RunStatusResult Sequencer::run_status(const std::string& run_id) const {
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
  protocol::RunStatusResult out;
  out.run_id = rec->run_id;
  out.state = rec->state;
  out.reason = rec->reason;
  out.unit_serial = rec->unit_serial;
  out.unit_type = rec->unit_type;
  out.program = rec->program_name;
  out.position = rec->positions_done;
  out.positions = rec->positions;
  out.positions_done = rec->positions_done;
  out.started_utc = rec->started_utc;
  out.ended_utc = rec->ended_utc;
  out.recording_path = rec->recording_path;
  out.has_result = !rec->result_path.empty();
  std::lock_guard lock(snapshot_mutex_);
  if (progress_ && progress_->run_id == id) {  // the live view of the active run
    out.state = progress_->state;
    out.position = progress_->position;
    out.phase = progress_->phase;
    out.eta_s = progress_->eta_s;
    out.positions_done = progress_->positions_done;
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

protocol::RunsPage Sequencer::runs_list(const RunPageQuery& query) const {
  const RunPage page = store_.page(query);
  return protocol::RunsPage{page.runs, page.more};
}

}  // namespace standcal::daemon
