#pragma once
// The run sequencer: the one thread that talks to the hardware. The socket server hands
// it commands (submit) and gets the answers back through each command's reply callback;
// while a run or a long stand command is in progress, every wait of that thread still
// takes commands, so `estop`, `run.pause`, `run.abort`, `stand.stop` and
// `operator.confirm` act at once and everything else gets `busy`.
//
// A run: [thermal wait] → per position: [re-mount: wait for operator.confirm] → move →
// wait in position → settle → sample the dwell → stability check (re-measure up to the
// configured count, then fault) → average → append to the recording and fsync → next;
// at the end the invariant fit (and the full-vector fit) stored as result.json.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "calib/noise_model.hpp"
#include "calib/programs.hpp"
#include "daemon/standcald/config.hpp"
#include "daemon/standcald/dwell.hpp"
#include "daemon/standcald/hardware.hpp"
#include "daemon/standcald/run_store.hpp"
#include "protocol/jsonrpc/messages.hpp"

namespace standcal::daemon {

class PositionWriter;  // one position's rows to the recording as they come (sequencer_run.cpp)

// The answer to one command: a result, or an error (code != 0).
struct Outcome {
  nlohmann::json result;
  int error_code = 0;
  std::string error_message;
};
using ReplyFn = std::function<void(Outcome)>;
// An event notification for subscribed clients (called on the sequencer thread).
using EventFn = std::function<void(const std::string& event, const nlohmann::json& params)>;

class Sequencer {
 public:
  Sequencer(DaemonConfig config, Hardware hardware, RunStore& store, EventFn events);
  ~Sequencer();
  Sequencer(const Sequencer&) = delete;
  Sequencer& operator=(const Sequencer&) = delete;

  void start();
  // Queues a command (any thread); `reply` is called exactly once, on the sequencer thread.
  // `requested_by` names the caller in the log lines that must say who did it (estop).
  void submit(std::string method, nlohmann::json params, ReplyFn reply,
              std::string requested_by = {});
  // SIGTERM: interrupt any run (it becomes `interrupted`), stop and disable the axes,
  // then end the thread. join() waits for that.
  void request_shutdown();
  void join();

  // Counts the thread's loop turns: it moves at least once a second while the thread is
  // healthy, so the watchdog pings only while it moves.
  std::uint64_t heartbeat() const { return heartbeat_.load(); }

  // Thread-safe views, answered without waiting for the hardware thread.
  protocol::StatusResult status() const;  // without `daemon`: the server's part
  protocol::RunStatusResult run_status(
      const std::string& run_id) const;  // empty: current or newest
  nlohmann::json run_result(const std::string& run_id) const;
  protocol::RunsPage runs_list(const RunPageQuery& query) const;
  // Where the configured stand can go (config stand.outer / stand.inner).
  StandLimits stand_limits() const;
  // The unit's configured bias wander (unit.bias_instability_ug, _tau_s [, _tau_max_s]).
  const GivenWander& unit_wander() const;

  // Whether this class has a handler for `method` (method_table.hpp routes here every
  // method whose executor is the sequencer; tests/daemon's MethodTable cases check both).
  static bool handles(std::string_view method);
  static std::vector<std::string_view> handled_methods();

 private:
  struct Command {
    std::string method;
    nlohmann::json params;
    ReplyFn reply;
    std::string requested_by;
  };
  enum class Mode { idle, command, run_active, run_paused, run_waiting_operator };
  enum class Interrupt { none = 0, pause = 1, abort = 2, shutdown = 3, estop = 4 };
  struct Interrupted {
    Interrupt kind;
  };

  // An answer that waits until what it reports is true: a pause, abort or resume until
  // the run is in that state, a stand.stop until the axes are still. A "state" in the
  // result becomes the state the run reached (an abort may overtake a pause).
  struct DeferredAnswer {
    ReplyFn reply;
    nlohmann::json result;
  };

  // How the sequencer answers one method (kBindings, sequencer.cpp): `at_any_time` first,
  // even while a run holds the stand (true: answered or deferred; false: not its case);
  // then, on an idle sequencer, `command` (a stand command that holds the stand until it
  // answers) or `run` (answers once the run is running, then runs it).
  using AnyTimeHandler = bool (Sequencer::*)(Command&);
  using CommandHandler = nlohmann::json (Sequencer::*)(const Command&);
  using RunHandler = nlohmann::json (Sequencer::*)(const nlohmann::json& params);
  struct Binding {
    std::string_view method;
    AnyTimeHandler at_any_time;
    CommandHandler command;
    RunHandler run;
  };
  static const Binding kBindings[];
  static const Binding* binding(std::string_view method);

  void thread_main();
  void handle(Command& cmd);
  bool run_held() const;
  bool estop_at_any_time(Command& cmd);
  // The run a run-targeted command names when it is not the active run (the caller
  // refuses it: acting on the active run instead would pause, abort or confirm a run the
  // operator did not mean); -32006 when no such run exists.
  std::optional<std::string> named_other_run(const Command& cmd) const;
  bool act_on_active_run(Command& cmd);  // run.pause, run.abort, operator.confirm
  bool resume_active_run(Command& cmd);  // run.resume of the paused run
  bool stand_stop(Command& cmd);
  void defer_answer(Command& cmd, nlohmann::json result);
  void answer_deferred(const std::string& run_state = {});
  nlohmann::json execute_command(const Command& cmd, CommandHandler handler);
  void raise_interrupt(Interrupt kind);
  // Takes pending commands; throws Interrupted when one asked to interrupt.
  void service();
  // Waits `real_s` seconds of real time, serving commands meanwhile; returns early once
  // `until` (checked after each command) holds.
  void wait_real(double real_s, const std::function<bool()>& until = {});

  // Stand and unit commands (sequencer_stand.cpp).
  nlohmann::json enable_stand(const Command& cmd);
  nlohmann::json disable_stand(const Command& cmd);
  nlohmann::json home_stand(const Command& cmd);
  nlohmann::json move_stand(const Command& cmd);
  nlohmann::json reset_estop(const Command& cmd);
  nlohmann::json read_unit(const Command& cmd);

  // Stand operations (throw protocol::RpcError).
  void prepare_stand(bool home_if_needed);
  void home_axes();
  drivers::WaitClock wait_clock();
  std::pair<double, double> move_and_wait(double alpha1_deg, double alpha2_deg);
  void start_move(double alpha1_deg, double alpha2_deg);
  std::pair<double, double> wait_in_position(double target1_deg, double target2_deg);
  void stop_axes_quietly();
  // Stops both axes and waits (serving no command) until neither moves nor homes, at
  // most in_position.timeout_s: a real drive decelerates. False when they still move.
  bool stop_axes_and_wait();
  void handle_emergency_stops();
  bool axes_still();
  void emergency_stop(const std::string& requested_by);
  drivers::AxisState read_axis(drivers::StandAxis axis);
  protocol::UnitReadResult unit_read(double seconds);
  // `seconds` of the unit's samples, each chunk to `take` as it comes (commands are served
  // between chunks), so that a long stretch need not be held whole.
  using SampleChunkFn = std::function<void(std::vector<drivers::AccelSample>&&)>;
  void collect(double seconds, const SampleChunkFn& take);
  // The unit started, `seconds` collected, the unit stopped (also when collecting throws).
  void sample_unit(double seconds, const SampleChunkFn& take);
  std::vector<drivers::AccelSample> sample_unit(double seconds);
  void refresh_stand_snapshot();

  // Runs (sequencer_run.cpp).
  nlohmann::json start_run(const nlohmann::json& params);
  nlohmann::json resume_run(const nlohmann::json& params);
  // Runs (or continues) `record`; `started` is called once the run is `running`, so the
  // run.start/run.resume answer never reaches a client before run.status says so.
  void run_loop(RunRecord record, const std::function<void()>& started);
  void measure_position(RunRecord& record, const Program& program, int index, RecordingFile& file);
  struct Arrival {
    std::pair<double, double> reached_deg;  // angles read back in position
    double t_arrive_s = 0;                  // run clock
    int approach = 0;                       // approach direction (calib/averaging.hpp)
  };
  Arrival arrive_at(const RunRecord& record, const ProgramPosition& pp, int index);
  struct SampledDwell {
    std::vector<drivers::AccelSample> samples;
    DwellAverage average;
    double t_first_s = 0;  // run clock at the first sample
  };
  SampledDwell sample_stable_dwell(const RunRecord& record, int index, double dwell_s);
  void warm_up(const RunRecord& record, double warmup_s, PositionWriter& rows);
  void start_dwell_pool(const RunRecord& record);
  void pool_recorded_dwells(const RunRecord& record);
  GivenWander recorded_run_wander(const RunRecord& record) const;
  void wait_for_operator(RunRecord& record, const Program& program, int index);
  void wait_thermal_stability(RunRecord& record);
  bool wait_while_paused(RunRecord& record);
  void finish_interrupted(RunRecord& record, Interrupt kind);
  void finish_with_fit(RunRecord& record);
  void set_state(RunRecord& record, const std::string& state, const std::string& reason = {});
  void set_progress(const RunRecord& record, int position, const std::string& phase);
  // Seconds on the stand's clock since the run began (continuing a resumed run's time).
  double run_clock_s() const;

  DaemonConfig config_;
  Hardware hw_;
  RunStore& store_;
  EventFn events_;

  std::thread thread_;
  std::atomic<std::uint64_t> heartbeat_{0};
  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Command> queue_;
  bool shutdown_ = false;  // guarded by queue_mutex_

  // Sequencer-thread state.
  Mode mode_ = Mode::idle;
  std::string busy_with_;  // what holds the hardware, for `busy` messages
  Interrupt interrupt_ = Interrupt::none;
  std::vector<DeferredAnswer> deferred_answers_;
  bool resume_requested_ = false;
  bool operator_confirmed_ = false;
  bool estop_latched_ = false;
  double run_clock_base_s_ = 0;
  double run_clock_start_s_ = 0;  // hw_.clock->now_s() when run_clock_base_s_ was taken
  double last_t_s_ = 0;
  std::pair<double, double> last_cmd_deg_{0, 0};
  std::optional<Mount> mounted_;     // how the unit is believed mounted; empty: ask the operator
  double mean_position_real_s_ = 0;  // for the ETA
  int positions_timed_ = 0;
  // The active run's dwells pooled, for the drift rule (stability.trend_limit_sigmas).
  std::optional<DwellSampleCorrelation> dwell_correlation_;
  // The unit's bias wander the active run's drift rule allows for: the one it was begun with
  // (the configured one then, its recording's header on resume), as its fits weigh with.
  GivenWander run_wander_;

  // Snapshot for the thread-safe views.
  mutable std::mutex snapshot_mutex_;
  protocol::StandStatus stand_snapshot_;
  std::optional<protocol::RunProgress> progress_;  // the active run's live progress
  std::string active_run_id_;
};

}  // namespace standcal::daemon
