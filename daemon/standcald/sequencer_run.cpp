#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <span>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/json_text.hpp"
#include "calib/recording.hpp"
#include "calib/text.hpp"
#include "calib/utc_time.hpp"
#include "daemon/standcald/dwell.hpp"
#include "daemon/standcald/run_result.hpp"
#include "daemon/standcald/sequencer.hpp"
#include "daemon/standcald/sequencer_detail.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "protocol/jsonrpc/text.hpp"
#include "standcal/version.hpp"

// The sequencer's runs: run.start and run.resume, the run loop (per position: re-mount,
// move, settle, dwell, stability check, record), pause and interrupt, and the fit at the
// end (run_result.hpp).
namespace standcal::daemon {

// The sequencer files' shared names: sequencer_detail.hpp.
using namespace detail;

// --------------------------------------------------------------------------- runs

namespace {

// What of `program`, from position `first` on, the daemon cannot hold, or "": a dwell is
// judged whole by the stability rule (kMaxDwellSamples); a warm-up is written as it comes but
// read whole by the run's fit (kMaxWarmupSamples). Refused before the stand moves.
std::string held_too_large(const Program& program, double dwell_s, double rate_hz, int first) {
  const auto whole = [](double v) { return fmt::format("{:.0f}", v); };
  for (auto i = static_cast<std::size_t>(first); i < program.positions.size(); ++i) {
    const double s = program.positions[i].dwell_s.value_or(dwell_s);
    if (!(s * rate_hz > kMaxDwellSamples)) continue;
    return fmt::format(
        "position {}'s dwell of {} s at {} Hz would be {} samples, more than the {} a dwell "
        "holds at once to be judged: give at most {} s (a long hold before position 1's dwell is "
        "its warm-up, warmup_s, written to the recording as it is taken)",
        i + 1, number_text(s), number_text(rate_hz), whole(s * rate_hz), whole(kMaxDwellSamples),
        number_text(most_seconds_of(kMaxDwellSamples, rate_hz)));
  }
  if (first == 0 && program.warmup_s * rate_hz > kMaxWarmupSamples)
    return fmt::format(
        "a warm-up of {} s at {} Hz would be {} samples, more than the {} the run's fit reads at "
        "once for its Allan curves: give at most {} s",
        number_text(program.warmup_s), number_text(rate_hz), whole(program.warmup_s * rate_hz),
        whole(kMaxWarmupSamples), number_text(most_seconds_of(kMaxWarmupSamples, rate_hz)));
  return "";
}

// A run's fault event: the run, the position when one is named, what happened.
protocol::FaultEvent run_fault(const std::string& run_id, std::string message,
                               std::optional<int> position = std::nullopt) {
  protocol::FaultEvent e;
  e.message = std::move(message);
  e.run_id = run_id;
  e.position = position;
  return e;
}

StandLimits limits_of(const DaemonConfig& c) { return StandLimits{c.outer, c.inner}; }

}  // namespace

StandLimits Sequencer::stand_limits() const { return limits_of(config_); }

const GivenWander& Sequencer::unit_wander() const { return config_.unit_wander; }

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
  const auto request = protocol::RunStartParams::parse(params);
  const std::string& serial = request.unit_serial;
  Program program = program_from_params(request.program, config_);
  protocol::require_text_field("run.start: the programme's \"name\"", program.name,
                               protocol::text_limit::program_name);
  try {
    program = normalise_program(program, limits_of(config_));
  } catch (const ProgramError& e) {
    throw RpcError(ErrorCode::limit, e.what());
  }
  const double dwell = request.dwell_s.value_or(config_.dwell_s);
  const double settle = request.settle_s.value_or(config_.settle_s);
  if (!(dwell > 0 && dwell <= kMaxDwell_s))
    throw RpcError(ErrorCode::invalid_params, "run.start: \"dwell_s\" must be in (0, 36000]");
  if (!(settle >= 0 && settle <= kMaxSettle_s))
    throw RpcError(ErrorCode::invalid_params, "run.start: \"settle_s\" must be in [0, 3600]");
  if (request.warmup_s) {
    // A named programme's warm-up without writing a programme file (the run's own wins).
    if (!(*request.warmup_s >= 0 && *request.warmup_s <= kMaxDwell_s))
      throw RpcError(ErrorCode::invalid_params, "run.start: \"warmup_s\" must be in [0, 36000]");
    program.warmup_s = *request.warmup_s;
  }
  if (const std::string why = held_too_large(program, dwell, config_.sample_rate_hz, 0);
      !why.empty())
    throw RpcError(ErrorCode::invalid_params, "run.start: " + why);
  // The readers refuse a warm-up of fewer than two rows: refused here, before the stand moves.
  if (const double shortest_s = 2 / config_.sample_rate_hz;
      program.warmup_s > 0 && program.warmup_s < shortest_s)
    throw RpcError(ErrorCode::invalid_params,
                   "run.start: a warm-up of " + number_text(program.warmup_s) +
                       " s holds fewer than two of the unit's samples at " +
                       number_text(config_.sample_rate_hz) + " Hz: give 0 (none) or at least " +
                       number_text(shortest_s) + " s");
  if (estop_latched_)
    throw RpcError(ErrorCode::estop_active, "emergency stop is latched: send estop.reset first");

  RunRecord r;
  r.run_id = store_.new_run_id(serial);
  r.unit_serial = serial;
  r.unit_type = request.unit_type.value_or("");
  r.program_name = program.name;
  r.program = program_to_json(program);
  r.dwell_s = dwell;
  r.settle_s = settle;
  r.operator_name = request.operator_name.value_or("");
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
  return protocol::RunStarted{r.run_id, r.positions, r.recording_path};
}

json Sequencer::resume_run(const json& params) {
  std::optional<RunRecord> rec;
  if (auto id = protocol::RunTargetParams::parse(params, m::run_resume).run_id) {
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
    const Program program = program_from_json(rec->program, rec->run_id);
    // ... or begun before the daemon's limits on what it holds, or under a lower sample rate.
    if (const std::string why =
            held_too_large(program, rec->dwell_s, config_.sample_rate_hz, rec->positions_done);
        !why.empty())
      throw ProgramError(why);
  } catch (const ProgramError& e) {
    throw RpcError(ErrorCode::invalid_state,
                   "run " + rec->run_id + " cannot be resumed: " + e.what());
  }
  spdlog::info("run {} resumed at position {}/{}", rec->run_id, rec->positions_done + 1,
               rec->positions);
  return protocol::RunResumed{rec->run_id, rec->positions_done + 1, rec->positions};
}

double Sequencer::run_clock_s() const {
  return run_clock_base_s_ + (hw_.clock->now_s() - run_clock_start_s_);
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
    if (progress_) progress_->state = state;
  }
  // The one log line of a state change; a fault is logged here once, at error level.
  const auto level = state == st::faulted ? spdlog::level::err : spdlog::level::info;
  if (reason.empty()) {
    spdlog::log(level, "run {}: {}", record.run_id, state);
  } else {
    spdlog::log(level, "run {}: {} ({})", record.run_id, state, reason);
  }
  events_(ev::run_state, protocol::RunStateEvent{record.run_id, state, reason,
                                                 record.positions_done, record.positions});
}

void Sequencer::set_progress(const RunRecord& record, int index, const std::string& phase) {
  const int remaining = std::max(0, record.positions - index);
  const double per_position_real_s =
      positions_timed_ > 0 ? mean_position_real_s_
                           : hw_.clock->real_seconds(record.dwell_s + record.settle_s +
                                                     10.0);  // 10 s: a typical move
  const protocol::RunProgress progress{
      record.run_id,         record.state, std::min(index + 1, record.positions), record.positions,
      record.positions_done, phase,        remaining * per_position_real_s};
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
      events_(ev::fault, run_fault(record.run_id, note));
    }
  }
  const bool fresh = record.recording_bytes == 0;
  run_clock_base_s_ =
      fresh ? 0.0 : record.last_t_s + 1.0;  // resumed: time continues after the last row
  run_clock_start_s_ = hw_.clock->now_s();
  last_t_s_ = record.last_t_s;
  positions_timed_ = 0;
  mean_position_real_s_ = 0;
  start_dwell_pool(record);
  run_wander_ = fresh ? unit_wander() : recorded_run_wander(record);
  mounted_ = (!fresh && uses_several_mounts(program))
                 ? std::nullopt
                 : std::optional<Mount>(program.positions.front().mount);
  if (fresh) hw_.remount(program.positions.front().mount);
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
            // Exactly: the recording is what every later fit of the run reads g from.
            header.set_header("g_local_mps2", round_trip_text(record.g_local_mps2));
            header.set_header("settle_s", round_trip_text(record.settle_s));
            header.set_header("sample_rate_hz", round_trip_text(config_.sample_rate_hz));
            header.set_header("unit_serial", record.unit_serial);
            if (!record.unit_type.empty()) header.set_header("unit_type", record.unit_type);
            header.set_header("program", record.program_name);
            header.set_header("started_utc", record.started_utc);
            header.set_header("run_id", record.run_id);
            header.set_header("stand_id", record.stand_id);
            // What the run's fits weigh with, and every later fit of its recording.
            set_unit_wander_header(header, run_wander_);
            // What its unit.static_recording gave it: the wander above, its curves or its floor
            // under the correlation time (below), or nothing and why.
            if (const auto& u = config_.unit_static_recording; u)
              header.set_header(kHeaderUnitWanderSource, unit_static_recording_words(*u));
            if (const auto& curves = config_.unit_static_curves_ug; curves)
              header.set_header(kHeaderUnitStaticCurves, wander_curves_text(*curves));
            if (const double floor_s = config_.unit_static_tau_floor_s; floor_s > 0)
              header.set_header(kHeaderUnitStaticTauFloorS, round_trip_text(floor_s));
            if (program.warmup_s > 0)
              header.set_header(kHeaderWarmupS, round_trip_text(program.warmup_s));
            header.columns = recording_columns(program);
            file.emplace(
                RecordingFile::create(record.recording_path, format_recording_header(header)));
            record.recording_bytes = file->length();
            record.header_bytes = file->length();
            record.position_end_bytes.clear();
            store_.save(record);
          } else {
            file.emplace(RecordingFile::reopen(record.recording_path, record.recording_bytes));
            pool_recorded_dwells(record);
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
    events_(ev::fault, run_fault(record.run_id, e.what()));
    set_state(record, st::faulted, e.what());
  }
  mode_ = Mode::idle;
  {
    std::lock_guard lock(snapshot_mutex_);
    active_run_id_.clear();
    progress_.reset();
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
  hw_.remount(mount);
  mounted_ = mount;
  set_state(record, st::running);
}

namespace {

// The least-squares slope of temperature against time over a window's samples, taken as they
// come (Welford's co-moments): a window of hours at a high rate is never held.
class TemperatureSlope {
 public:
  void add(const drivers::AccelSample& x) {
    if (!std::isfinite(x.temperature_c)) return;
    if (n_ == 0) t0_s_ = x.t_s;  // times from the first: a clock's 1.8e9 s cost digits
    const double t = x.t_s - t0_s_;
    n_ += 1;
    const double dt = t - t_mean_;
    t_mean_ += dt / n_;
    c_mean_ += (x.temperature_c - c_mean_) / n_;
    stt_ += dt * (t - t_mean_);
    stc_ += dt * (x.temperature_c - c_mean_);
  }
  double samples() const { return n_; }
  double c_per_min() const { return stt_ > 0 ? stc_ / stt_ * 60.0 : 0.0; }

 private:
  double t0_s_ = 0, n_ = 0, t_mean_ = 0, c_mean_ = 0, stt_ = 0, stc_ = 0;
};

}  // namespace

void Sequencer::wait_thermal_stability(RunRecord& record) {
  const ThermalWait& tw = config_.thermal;
  set_progress(record, 0, "thermal_wait");
  const double start = run_clock_s();
  for (;;) {
    TemperatureSlope slope;
    sample_unit(tw.window_s, [&](std::vector<drivers::AccelSample>&& chunk) {
      for (const drivers::AccelSample& x : chunk) slope.add(x);
    });
    if (slope.samples() < 2)
      throw RpcError(ErrorCode::hardware_fault,
                     "thermal wait is configured but the unit reports no temperature");
    const double rate_c_per_min = slope.c_per_min();
    if (std::abs(rate_c_per_min) < tw.rate_limit_c_per_min) return;
    if (run_clock_s() - start > tw.timeout_s) {
      const auto [rate, limit] = number_texts_apart(rate_c_per_min, tw.rate_limit_c_per_min);
      throw RpcError(ErrorCode::hardware_fault,
                     "the unit temperature still changes by " + rate + " °C/min (limit " + limit +
                         " °C/min) after the thermal wait's " + number_text(tw.timeout_s) + " s");
    }
  }
}

// One position's rows, written to the recording as its samples come, a slice at a time: a
// warm-up of hours is never held whole (held until the position ended, four runs' warm-ups of
// 7200 s at 100 Hz had peaked the daemon at 184 MB against 47 MB now, the run's fit: see
// kMaxWarmupSamples and docs/reliability.md, "A long warm-up"). Not durable until synced.
class PositionWriter {
 public:
  // `fixed`: the fields every row of the position shares (position, angles, arrival, mount).
  PositionWriter(RecordingFile& file, const RecordingColumns& columns, const RecordingSample& fixed)
      : file_(file), columns_(columns), fixed_(fixed) {}

  // The rows of `samples` on the run clock: the unit's time t0_unit_s is the run's t_first_s
  // (the unit's own sample spacing from when sampling began).
  void append(std::span<const drivers::AccelSample> samples, double t_first_s, double t0_unit_s) {
    constexpr std::size_t kRowsPerWrite = 1 << 14;
    for (std::size_t begin = 0; begin < samples.size(); begin += kRowsPerWrite) {
      rows_.clear();
      for (const drivers::AccelSample& x :
           samples.subspan(begin, std::min(kRowsPerWrite, samples.size() - begin)))
        rows_.push_back(row(x, t_first_s + (x.t_s - t0_unit_s)));
      text_.clear();
      append_recording_rows(text_, columns_, rows_);
      file_.append(text_);
      last_t_s_ = rows_.back().t_s;
    }
  }
  double last_t_s() const { return last_t_s_; }  // NaN before the first row

 private:
  RecordingSample row(const drivers::AccelSample& x, double t_s) const {
    RecordingSample r = fixed_;
    r.t_s = t_s;
    r.f_mps2 = Vec3(x.force_mps2[0], x.force_mps2[1], x.force_mps2[2]);
    r.temp_c = std::isfinite(x.temperature_c) ? x.temperature_c : kNoValue;
    return r;
  }

  RecordingFile& file_;
  const RecordingColumns& columns_;
  RecordingSample fixed_;
  std::vector<RecordingSample> rows_;
  std::string text_;
  double last_t_s_ = kNoValue;
};

namespace {

std::array<double, 3> per_axis_ug(const std::array<double, 3>& mps2, double g_local_mps2) {
  std::array<double, 3> ug{};
  for (std::size_t a = 0; a < 3; ++a) ug[a] = mps2[a] / g_local_mps2 * 1e6;
  return ug;
}

}  // namespace

// One position: re-mount if its mount differs, move and wait in position, settle, sample a
// stable dwell, append it to the recording durably, and only then count it done.
void Sequencer::measure_position(RunRecord& record, const Program& program, int index,
                                 RecordingFile& file) {
  const ProgramPosition& pp = program.positions[static_cast<std::size_t>(index)];
  const double started_real = now_real_s();
  if (!mounted_ || *mounted_ != pp.mount) wait_for_operator(record, program, index);
  const Arrival arrival = arrive_at(record, pp, index);

  set_progress(record, index, "settling");
  wait_real(hw_.clock->real_seconds(pp.settle_s.value_or(record.settle_s)));
  const RecordingColumns columns = recording_columns(program);
  RecordingSample fixed;
  fixed.pos = index;
  fixed.alpha1_cmd_deg = pp.alpha1_deg;
  fixed.alpha2_cmd_deg = pp.alpha2_deg;
  fixed.alpha1_deg = arrival.reached_deg.first;
  fixed.alpha2_deg = arrival.reached_deg.second;
  if (columns.mount) fixed.mount = pp.mount;
  fixed.t_arrive_s = arrival.t_arrive_s;
  fixed.approach = static_cast<std::int8_t>(arrival.approach);
  PositionWriter rows(file, columns, fixed);
  double warm_up_real_s = 0;  // not a position's time: kept out of the ETA's mean
  SampledDwell dwell;
  try {
    if (index == 0 && program.warmup_s > 0) {
      const double warm_up_started = now_real_s();
      warm_up(record, program.warmup_s, rows);
      warm_up_real_s = now_real_s() - warm_up_started;
    }
    dwell = sample_stable_dwell(record, index, pp.dwell_s.value_or(record.dwell_s));
    rows.append(dwell.samples, dwell.t_first_s, dwell.samples.front().t_s);
    record.recording_bytes = file.sync();
  } catch (...) {
    // A fault, a pause or an abort inside the position: the file keeps whole positions only
    // (run.resume continues this one on the same file; a faulted run's recording is read).
    // The exception that got here is what the run answers to; a cut that fails is logged (a
    // resume cuts the file back to run.json's length as it reopens it).
    try {
      file.cut_back(record.recording_bytes);
    } catch (const std::exception& e) {
      spdlog::error("run {}: position {} left part-written in the recording: {}", record.run_id,
                    index + 1, e.what());
    }
    throw;
  }
  record.position_end_bytes.resize(static_cast<std::size_t>(index));
  record.position_end_bytes.push_back(record.recording_bytes);
  record.positions_done = index + 1;
  record.last_t_s = rows.last_t_s();
  last_t_s_ = record.last_t_s;
  store_.save(record);  // only now is the position done: a crash before this re-measures it

  const DwellAverage& avg = dwell.average;
  protocol::PositionAveraged averaged{record.run_id,
                                      index + 1,
                                      index,
                                      static_cast<std::int64_t>(dwell.samples.size()),
                                      avg.mean_mps2,
                                      per_axis_ug(avg.sigma_mps2, record.g_local_mps2),
                                      per_axis_ug(avg.trend_mps2, record.g_local_mps2),
                                      std::nullopt};
  if (std::isfinite(avg.temp_mean_c)) averaged.temp_c = avg.temp_mean_c;
  events_(ev::position_averaged, averaged);
  const double took = now_real_s() - started_real - warm_up_real_s;
  mean_position_real_s_ =
      (mean_position_real_s_ * positions_timed_ + took) / (positions_timed_ + 1);
  ++positions_timed_;
  set_progress(record, index + 1, "moving");
}

// Moves to the position and waits in position; says where the stand arrived.
Sequencer::Arrival Sequencer::arrive_at(const RunRecord& record, const ProgramPosition& pp,
                                        int index) {
  set_progress(record, index, "moving");
  if (hw_.stand->lifecycle() != drivers::Lifecycle::active) {
    // The driver dropped to `error` (link lost after its retries) while the unit sampled.
    throw RpcError(ErrorCode::hardware_fault, "lost the link to the stand " + hw_.stand->name() +
                                                  " during the run (" +
                                                  drivers::to_string(hw_.stand->lifecycle()) +
                                                  "); run.resume reconnects and continues");
  }
  Arrival a;
  a.reached_deg = move_and_wait(pp.alpha1_deg, pp.alpha2_deg);
  a.t_arrive_s = std::max(run_clock_s(), last_t_s_);
  a.approach = approach_directions({last_cmd_deg_, {pp.alpha1_deg, pp.alpha2_deg}})[1];
  last_cmd_deg_ = {pp.alpha1_deg, pp.alpha2_deg};
  events_(ev::position_reached,
          protocol::PositionReached{record.run_id, index + 1, index, pp.alpha1_deg, pp.alpha2_deg,
                                    a.reached_deg.first, a.reached_deg.second, a.t_arrive_s});
  return a;
}

// The drift rule's pool of the run's dwells (only when the rule is asked for), empty.
void Sequencer::start_dwell_pool(const RunRecord& record) {
  dwell_correlation_.reset();
  if (!(config_.stability.trend_limit_sigmas > 0) || !(config_.sample_rate_hz > 0)) return;
  dwell_correlation_.emplace(1 / config_.sample_rate_hz, record.g_local_mps2);
}

namespace {
// Reads nothing but a recording's header.
struct HeaderOnly : RecordingRowSink {
  void header(const Recording&) override {}
  void row(const RecordingSample&) override {}
};
}  // namespace

// The unit's wander a resumed run was begun with, as its recording's header keeps it (what
// its fits weigh with: fit_finished_run), none included; the configured one where the header
// says nothing of it (a run begun before headers carried it: header_silent_on_unit_wander) or
// cannot be read (the reopened recording is checked as it is read on).
GivenWander Sequencer::recorded_run_wander(const RunRecord& record) const {
  const auto size_text = [](const GivenWander& w) {
    if (w.size_axes_ug.isZero()) return number_text(w.size_ug) + " µg";
    const Vec3 q = w.size_axes_ug;
    return axes_text("%.6g", q[0], q[1], q[2], "µg");  // number_text's digits
  };
  if (!(config_.stability.trend_limit_sigmas > 0)) return unit_wander();  // the rule is off
  try {
    HeaderOnly sink;
    RecordingReader reader(record.recording_path);
    const Recording& header = reader.read_header(sink);
    if (header_silent_on_unit_wander(header)) return unit_wander();
    const GivenWander begun_with = given_wander_of(header.unit_wander);
    const auto wander_text = [&](const GivenWander& w) {
      return w.given() ? size_text(w) + " at tau " + number_text(w.specified().tau_s) + " s"
                       : std::string("none");
    };
    if (begun_with.axes_ug() != unit_wander().axes_ug() ||
        begun_with.specified().tau_s != unit_wander().specified().tau_s)
      spdlog::info(
          "run {}: the drift rule allows for the unit's bias wander the run was begun with, "
          "{} (its recording's header), not the configured {}",
          record.run_id, wander_text(begun_with), wander_text(unit_wander()));
    return begun_with;
  } catch (const std::exception& e) {
    spdlog::warn(
        "run {}: its recording's header cannot be read ({}); the drift rule allows "
        "for the configured bias wander",
        record.run_id, e.what());
    return unit_wander();
  }
}

// A resumed run's dwells so far, read once its recording is reopened (and cut back to the
// positions done): streamed, after the run.resume answer.
void Sequencer::pool_recorded_dwells(const RunRecord& record) {
  if (!dwell_correlation_) return;
  try {
    const std::size_t dwells = dwell_correlation_->add_recorded_dwells(record.recording_path);
    const std::array<double, 3> w = dwell_correlation_->widening();
    spdlog::info(
        "run {}: the drift rule pools the {} dwells of its recording (samples' correlation "
        "widens the white noise x {:.3g}, y {:.3g}, z {:.3g})",
        record.run_id, dwells, w[0], w[1], w[2]);
  } catch (const std::exception& e) {
    // The drift rule then judges the remaining dwells from them alone.
    spdlog::warn("run {}: the drift rule pools only the dwells from here on: {}", record.run_id,
                 e.what());
  }
}

// The first position's warm-up (Program::warmup_s): the unit sampled ahead of the dwell, its
// rows written to the recording as they come, in the same block (Recording::warmup_s: they
// feed the noise model's Allan curves and stay out of the position's mean). The drift rule
// does not judge it: a warm-up is where the unit settles.
void Sequencer::warm_up(const RunRecord& record, double warmup_s, PositionWriter& rows) {
  set_progress(record, 0, "warming_up");
  const double t_first_s = std::max(run_clock_s(), last_t_s_ + 1e-3);
  // Exactly the rows the readers take for the warm-up (within warmup_s of its first): a sample
  // at warmup_s itself could read either way once its time is written, and a unit's own
  // stamps need not step at exactly its period, so the warm-up ends half a period before.
  const double end_s = warmup_s - 0.5 / config_.sample_rate_hz;
  double t0_unit_s = kNoValue;
  std::size_t kept = 0;
  sample_unit(warmup_s, [&](std::vector<drivers::AccelSample>&& chunk) {
    if (chunk.empty()) return;
    if (!std::isfinite(t0_unit_s)) t0_unit_s = chunk.front().t_s;
    std::erase_if(chunk,
                  [&](const drivers::AccelSample& x) { return !(x.t_s - t0_unit_s < end_s); });
    rows.append(chunk, t_first_s, t0_unit_s);
    kept += chunk.size();
  });
  if (!std::isfinite(t0_unit_s))
    throw RpcError(ErrorCode::hardware_fault,
                   "the unit " + hw_.unit->name() + " sent no sample in the " +
                       number_text(warmup_s) + " s warm-up of position 1");
  if (kept < 2)  // run.start refuses so short a warm-up; a run begun before did not
    throw RpcError(ErrorCode::hardware_fault, "the " + number_text(warmup_s) +
                                                  " s warm-up of position 1 holds fewer than "
                                                  "two samples of the unit " +
                                                  hw_.unit->name());
  // The readers take the block's rows within warmup_s of its first as the warm-up: the
  // dwell's rows begin after that.
  last_t_s_ = std::max(rows.last_t_s(), t_first_s + warmup_s);
}

// Samples `dwell_s` of unit time; a dwell the stability rule rejects is re-measured up to
// stability.remeasure_max times, then the run faults saying why.
Sequencer::SampledDwell Sequencer::sample_stable_dwell(const RunRecord& record, int index,
                                                       double dwell_s) {
  for (int attempt = 0;; ++attempt) {
    set_progress(record, index, attempt == 0 ? "sampling" : "re-measuring");
    const std::uint64_t incomplete_before = hw_.unit->health().incomplete_samples;
    SampledDwell d;
    d.t_first_s = std::max(run_clock_s(), last_t_s_ + 1e-3);
    d.samples = sample_unit(dwell_s);
    d.average = average_dwell(d.samples);
    DwellExpectation expected{hw_.unit->name(), dwell_s, config_.sample_rate_hz,
                              hw_.unit->health().incomplete_samples - incomplete_before,
                              record.g_local_mps2};
    const Vec3 wander_ug = run_wander_.axes_ug();  // each axis's own
    expected.bias_wander_ug = {wander_ug[0], wander_ug[1], wander_ug[2]};
    expected.bias_wander_tau_s = run_wander_.specified().tau_s;
    if (dwell_correlation_ && implausible_reading(d.average).empty())
      expected.sample_correlation_widening = dwell_correlation_->add_dwell(d.samples, d.average);
    const std::string problem = dwell_problem(d.average, expected, config_.stability);
    if (problem.empty()) return d;
    if (attempt >= config_.stability.remeasure_max) {
      throw RpcError(ErrorCode::hardware_fault,
                     "position " + std::to_string(index + 1) + " not stable after " +
                         std::to_string(attempt + 1) + " measurements: " + problem);
    }
    spdlog::warn("run {}: re-measuring position {}: {}", record.run_id, index + 1, problem);
    events_(ev::fault,
            run_fault(record.run_id,
                      "re-measuring position " + std::to_string(index + 1) + ": " + problem,
                      index + 1));
  }
}

void Sequencer::finish_with_fit(RunRecord& record) {
  set_progress(record, record.positions, "fitting");
  json result =
      fit_finished_run(record, store_.run_dir(record.run_id), unit_wander(), config_.budget);
  const std::string path = store_.run_dir(record.run_id) + "/result.json";
  write_state_file(path, json_text(result) + "\n");
  record.result_path = path;
  set_state(record, st::done);
}

}  // namespace standcal::daemon
