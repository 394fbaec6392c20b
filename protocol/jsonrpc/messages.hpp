#pragma once
// The protocol's messages as types (docs/protocol.md; chrony's candm.h, gpsd's one dump
// function per class): every request's parameters, every result and every event that
// standcald and the standcal CLI exchange, each with its JSON form. The daemon builds its
// answers and events from these and reads requests through them; the CLI sends requests
// and reads answers through them. tests/protocol/messages_test.cpp checks each type's keys
// against docs/protocol.md.
//
// Results and events: to_json writes every member (an empty optional as null); from_json
// keeps a member's default when its key is absent (an older daemon). Requests: parse()
// reads the daemon's side with protocol::Params (its errors name the method and the
// parameter), to_json writes the CLI's side without the optionals left unset.
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace standcal::protocol {

using nlohmann::json;

// A member that may be null in JSON (a run's phase, a temperature no sample carried): an
// optional with its JSON form, found by argument-dependent lookup (a specialisation of
// nlohmann::adl_serializer for std::optional would have to precede every use of one).
template <typename T>
struct Nullable : std::optional<T> {
  using std::optional<T>::optional;
  Nullable() = default;
  Nullable(const std::optional<T>& v) : std::optional<T>(v) {}  // NOLINT: implicit on purpose
};

template <typename T>
void to_json(json& j, const Nullable<T>& v) {
  if (v)
    j = *v;
  else
    j = nullptr;
}

template <typename T>
void from_json(const json& j, Nullable<T>& v) {
  if (j.is_null())
    v.reset();
  else
    v = j.get<T>();
}

// ------------------------------------------------------------------ requests (params)

// stand.move
struct StandMoveParams {
  double alpha1_deg = 0;
  double alpha2_deg = 0;
  bool wait = true;
  static StandMoveParams parse(const json& params);
};

// unit.read
struct UnitReadParams {
  double seconds = 1;
  static UnitReadParams parse(const json& params);
};

// run.start. `program`: a name (paper9, classic24, a library file) or inline positions
// (an array, or an object {name, positions}), as docs/protocol.md says.
struct RunStartParams {
  json program;
  std::string unit_serial;
  std::optional<std::string> unit_type;
  std::optional<double> dwell_s;
  std::optional<double> settle_s;
  std::optional<double> warmup_s;            // the programme's warm-up, in place of its own
  std::optional<std::string> operator_name;  // "operator" on the wire
  static RunStartParams parse(const json& params);
};

// run.pause, run.resume, run.abort, run.status, operator.confirm: the run they act on
// (absent: the active run; for run.resume the newest resumable; for run.status the
// active, else the newest).
struct RunTargetParams {
  std::optional<std::string> run_id;
  static RunTargetParams parse(const json& params, const std::string& method);
};

// run.result
struct RunResultParams {
  std::string run_id;
  static RunResultParams parse(const json& params);
};

// run.diagnose
struct RunDiagnoseParams {
  std::string run_id;
  bool report = false;
  static RunDiagnoseParams parse(const json& params);
};

// runs.list
struct RunsListParams {
  std::optional<std::string> unit_serial;
  std::optional<int> limit;  // 1 ... runs_list_max_limit; absent: runs_list_default_limit
  std::optional<std::string> before;
  static RunsListParams parse(const json& params);
};

// subscribe: "all" or a list of event names; absent: all.
struct SubscribeParams {
  std::optional<std::vector<std::string>> events;  // empty optional: every event
  static SubscribeParams parse(const json& params);
};

// auth (TCP only)
struct AuthParams {
  std::string token;
  static AuthParams parse(const json& params);
};

// Methods with no parameters: status, stand.enable, stand.disable, stand.home,
// stand.stop, estop, estop.reset. Any key is an error naming it.
void parse_no_params(const json& params, const std::string& method);

void to_json(json& j, const StandMoveParams& p);
void to_json(json& j, const UnitReadParams& p);
void to_json(json& j, const RunStartParams& p);
void to_json(json& j, const RunTargetParams& p);
void to_json(json& j, const RunResultParams& p);
void to_json(json& j, const RunDiagnoseParams& p);
void to_json(json& j, const RunsListParams& p);
void to_json(json& j, const SubscribeParams& p);
void to_json(json& j, const AuthParams& p);

// ------------------------------------------------------------------ results

struct EnabledResult {  // stand.enable, stand.disable
  bool enabled = false;
};

struct HomedResult {  // stand.home: the angles read once both axes are homed
  double alpha1_deg = 0;
  double alpha2_deg = 0;
};

struct MoveResult {  // stand.move with wait: the angles read in position
  double alpha1_deg = 0;
  double alpha2_deg = 0;
  bool in_position = true;
};

struct MoveAccepted {  // stand.move with wait: false
  bool accepted = true;
};

struct StoppedResult {  // stand.stop
  bool stopped = true;
};

struct EstopResult {  // estop, estop.reset
  bool estop = false;
  std::string message;
};

struct UnitAxisReading {
  double mean_mps2 = 0;
  double sigma_ug = 0;
};

struct UnitAxesReading {
  UnitAxisReading x, y, z;
};

struct UnitReadResult {  // unit.read
  std::int64_t samples = 0;
  double rate_hz = 0;
  UnitAxesReading axes;
  Nullable<double> temp_c;  // null: the unit sent no temperature
  std::uint64_t incomplete_samples = 0;
};

struct RunStarted {  // run.start
  std::string run_id;
  int positions = 0;
  std::string recording_path;
};

struct RunStateResult {  // run.pause, run.abort, run.resume of a paused run
  std::string run_id;
  std::string state;
};

struct RunResumed {  // run.resume of a stored (interrupted, faulted) run
  std::string run_id;
  int position = 0;  // 1-based, the next to measure
  int positions = 0;
};

struct ConfirmedResult {  // operator.confirm
  std::string run_id;
  bool confirmed = true;
};

struct RunStatusResult {  // run.status
  std::string run_id;
  std::string state;
  std::string reason;
  std::string unit_serial;
  std::string unit_type;
  std::string program;
  int position = 0;
  int positions = 0;
  int positions_done = 0;
  Nullable<std::string> phase;  // active runs only
  Nullable<double> eta_s;       // active runs only
  std::string started_utc;
  std::string ended_utc;
  std::string recording_path;
  bool has_result = false;
};

struct RunListEntry {
  std::string run_id;
  std::string unit_serial;
  std::string program;
  std::string state;
  int positions = 0;
  int positions_done = 0;
  std::string started_utc;
  std::string ended_utc;
  bool has_result = false;
};

struct RunsPage {  // runs.list
  std::vector<RunListEntry> runs;
  bool more = false;
};

struct SubscribedResult {  // subscribe
  std::vector<std::string> events;
};

struct AuthResult {  // auth
  bool control = true;
};

// status: the daemon, the stand and unit, the active run (null when none), the backends.
struct AccessInfo {  // what this connection may do
  Nullable<std::string> control_group;
  bool tcp_token = false;
  std::string peer;
  bool control = false;
};

struct DaemonInfo {
  std::string version;
  std::string protocol;
  double uptime_s = 0;
  std::int64_t clients = 0;
  std::int64_t max_clients = 0;
  std::int64_t requests = 0;
  std::int64_t dropped_clients = 0;
  std::string state_dir;
  std::string socket;
  Nullable<int> tcp_port;
  AccessInfo access;
};

// One axis as the stand reported it, or the error that kept it from reporting (then only
// `axis` and `error` are in the JSON).
struct AxisStatus {
  std::string axis;
  std::string mode;
  double angle_deg = 0;
  bool enabled = false;
  bool homed = false;
  bool estop = false;
  bool stopped_by_heartbeat = false;
  int fault_code = 0;
  std::string fault_text;
  Nullable<std::string> error;
};
void to_json(json& j, const AxisStatus& a);
void from_json(const json& j, AxisStatus& a);

struct UnitStatus {
  std::string name;
  std::uint64_t samples = 0;
  std::uint64_t incomplete_samples = 0;
  std::string bus_state;
  bool silent = false;
};

struct StandStatus {
  std::string id;
  std::string name;
  std::string lifecycle;
  bool estop_latched = false;
  Nullable<std::string> busy_with;  // the stand command in progress
  std::vector<AxisStatus> axes;
  UnitStatus unit;
};

struct BackendInfo {
  std::string stand;
  std::string unit;
  bool simulated = false;  // the stand or the unit is the simulator
  std::string description;
};

// ------------------------------------------------------------------ events

// hello, the daemon's greeting on connect; on an estop-only slot also estop_only and a
// message (absent otherwise).
struct Hello {
  std::string daemon = "standcald";
  std::string version;
  std::string protocol;
  std::int64_t max_request_bytes = 0;
  Nullable<bool> estop_only;
  Nullable<std::string> message;
};
void to_json(json& j, const Hello& h);
void from_json(const json& j, Hello& h);

// run.progress, at every phase change; also status's `run`.
struct RunProgress {
  std::string run_id;
  std::string state;
  int position = 0;  // 1-based
  int positions = 0;
  int positions_done = 0;
  std::string phase;
  double eta_s = 0;  // real seconds left
};

struct StatusResult {  // status
  DaemonInfo daemon;
  StandStatus stand;
  Nullable<RunProgress> run;  // null when no run is active
  BackendInfo backend;
};

struct PositionReached {  // run.position_reached
  std::string run_id;
  int position = 0;  // 1-based
  int pos = 0;       // the recording's pos index
  double alpha1_cmd_deg = 0;
  double alpha2_cmd_deg = 0;
  double alpha1_deg = 0;
  double alpha2_deg = 0;
  double t_arrive_s = 0;
};

struct PositionAveraged {  // run.position_averaged
  std::string run_id;
  int position = 0;
  int pos = 0;
  std::int64_t samples = 0;
  std::array<double, 3> mean_mps2{};
  std::array<double, 3> sigma_ug{};
  std::array<double, 3> trend_ug{};
  Nullable<double> temp_c;
};

struct RunStateEvent {  // run.state, at every state change
  std::string run_id;
  std::string state;
  std::string reason;
  int positions_done = 0;
  int positions = 0;
};

// fault: a run's fault or re-measurement (run_id, and position when one is named), or an
// e-stop (source "estop"). Absent members are left out of the JSON.
struct FaultEvent {
  std::string message;
  Nullable<std::string> run_id;
  Nullable<int> position;
  Nullable<std::string> source;
};
void to_json(json& j, const FaultEvent& e);
void from_json(const json& j, FaultEvent& e);

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(EnabledResult, enabled)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(HomedResult, alpha1_deg, alpha2_deg)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(MoveResult, alpha1_deg, alpha2_deg, in_position)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(MoveAccepted, accepted)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StoppedResult, stopped)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(EstopResult, estop, message)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(UnitAxisReading, mean_mps2, sigma_ug)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(UnitAxesReading, x, y, z)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(UnitReadResult, samples, rate_hz, axes, temp_c,
                                                incomplete_samples)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunStarted, run_id, positions, recording_path)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunStateResult, run_id, state)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunResumed, run_id, position, positions)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(ConfirmedResult, run_id, confirmed)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunStatusResult, run_id, state, reason, unit_serial,
                                                unit_type, program, position, positions,
                                                positions_done, phase, eta_s, started_utc,
                                                ended_utc, recording_path, has_result)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunListEntry, run_id, unit_serial, program, state,
                                                positions, positions_done, started_utc, ended_utc,
                                                has_result)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunsPage, runs, more)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(SubscribedResult, events)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(AuthResult, control)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(AccessInfo, control_group, tcp_token, peer, control)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(DaemonInfo, version, protocol, uptime_s, clients,
                                                max_clients, requests, dropped_clients, state_dir,
                                                socket, tcp_port, access)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(UnitStatus, name, samples, incomplete_samples,
                                                bus_state, silent)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StandStatus, id, name, lifecycle, estop_latched,
                                                busy_with, axes, unit)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(BackendInfo, stand, unit, simulated, description)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunProgress, run_id, state, position, positions,
                                                positions_done, phase, eta_s)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StatusResult, daemon, stand, run, backend)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(PositionReached, run_id, position, pos,
                                                alpha1_cmd_deg, alpha2_cmd_deg, alpha1_deg,
                                                alpha2_deg, t_arrive_s)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(PositionAveraged, run_id, position, pos, samples,
                                                mean_mps2, sigma_ug, trend_ug, temp_c)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunStateEvent, run_id, state, reason,
                                                positions_done, positions)

}  // namespace standcal::protocol
