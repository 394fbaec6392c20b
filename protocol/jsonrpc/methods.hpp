#pragma once
// The names fixed by the protocol (docs/protocol.md): methods, events, run states.
#include <cstddef>

namespace standcal::protocol {

namespace method {
inline constexpr const char* hello = "hello";  // notification sent by the daemon on connect
inline constexpr const char* status = "status";
inline constexpr const char* stand_enable = "stand.enable";
inline constexpr const char* stand_disable = "stand.disable";
inline constexpr const char* stand_home = "stand.home";
inline constexpr const char* stand_move = "stand.move";
inline constexpr const char* stand_stop = "stand.stop";
inline constexpr const char* estop = "estop";
inline constexpr const char* estop_reset = "estop.reset";
inline constexpr const char* unit_read = "unit.read";
inline constexpr const char* run_start = "run.start";
inline constexpr const char* run_pause = "run.pause";
inline constexpr const char* run_resume = "run.resume";
inline constexpr const char* run_abort = "run.abort";
inline constexpr const char* run_status = "run.status";
inline constexpr const char* run_result = "run.result";
inline constexpr const char* run_diagnose = "run.diagnose";  // answered from a worker thread
inline constexpr const char* runs_list = "runs.list";
inline constexpr const char* operator_confirm = "operator.confirm";
inline constexpr const char* subscribe = "subscribe";
inline constexpr const char* auth =
    "auth";  // {token}: a TCP client asks for control (docs/security.md)
}  // namespace method

// runs.list pages: how many runs an answer holds when `limit` is not given, and at most.
inline constexpr int runs_list_default_limit = 100;
inline constexpr int runs_list_max_limit = 1000;

// Longest text fields, in characters (UTF-8 code points): run.start's unit_serial (at
// least 1), unit_type, operator and programme name, and any run id a request names.
namespace text_limit {
inline constexpr std::size_t unit_serial = 64;
inline constexpr std::size_t unit_type = 64;
inline constexpr std::size_t operator_name = 128;
inline constexpr std::size_t program_name = 128;  // "follow-up of RUN_ID" must fit
inline constexpr std::size_t run_id =
    128;  // ids are at most 85: stamp, serial made file-safe, suffix
}  // namespace text_limit

// Event notifications (method = the event name), sent to clients that subscribed.
namespace event {
inline constexpr const char* run_progress = "run.progress";  // position i/N, phase, ETA
inline constexpr const char* position_reached = "run.position_reached";
inline constexpr const char* position_averaged = "run.position_averaged";  // mean, sigma per axis
inline constexpr const char* run_state = "run.state";                      // state changes
inline constexpr const char* fault = "fault";
}  // namespace event

namespace run_state {
inline constexpr const char* running = "running";
inline constexpr const char* paused = "paused";
inline constexpr const char* waiting_operator = "waiting_operator";
inline constexpr const char* done = "done";
inline constexpr const char* aborted = "aborted";
inline constexpr const char* faulted = "faulted";
inline constexpr const char* interrupted = "interrupted";
}  // namespace run_state

}  // namespace standcal::protocol
