// Operator commands of standcald (docs/protocol.md): status, run start/watch/result/diagnose/
// resume/pause/abort/confirm, estop, runs. Each talks to the daemon's socket with the
// protocol library's client; `--json` prints the daemon's answer as it came.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "calib/atomic_file.hpp"
#include "calib/averaging.hpp"
#include "calib/compensation.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"
#include "calib/report.hpp"
#include "calib/traceability.hpp"
#include "protocol/jsonrpc/client.hpp"
#include "protocol/jsonrpc/messages.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/daemon_connection.hpp"

namespace standcal::cli {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

// Calls a method; daemon errors become the one-line reason main() prints.
json call(protocol::Client& c, const std::string& method, const json& params = json::object(),
          std::chrono::milliseconds timeout = 30s) {
  try {
    return c.call(method, params, timeout);
  } catch (const protocol::RpcError& e) {
    throw std::runtime_error(method + ": " + e.what() + " (" + protocol::error_code_name(e.code()) +
                             ")");
  }
}

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const long t = std::lround(s);
  char buf[32];
  if (t >= 3600) {
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  }
  return buf;
}

// A run's progress as one line: a bar of the positions done, the position, the phase (or
// the state, when the run has no phase) and the time left.
std::string progress_line(int pos, int n, int done, const std::string& phase,
                          std::optional<double> eta_s) {
  const int width = 20;
  const int filled = n > 0 ? done * width / n : 0;
  std::string bar = "[" + std::string(static_cast<std::size_t>(filled), '#') +
                    std::string(static_cast<std::size_t>(width - filled), '.') + "]";
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s position %d/%d  %-16s ETA %s", bar.c_str(), pos, n,
                phase.c_str(), eta_s ? duration_text(*eta_s).c_str() : "?");
  return buf;
}

std::string progress_line(const protocol::RunProgress& p) {
  return progress_line(p.position, p.positions, p.positions_done, p.phase, p.eta_s);
}

std::string progress_line(const protocol::RunStatusResult& s) {
  return progress_line(s.position, s.positions, s.positions_done, s.phase.value_or(s.state),
                       s.eta_s);
}

bool terminal_state(const std::string& s) {
  return s == "done" || s == "aborted" || s == "faulted" || s == "interrupted";
}

void print_axis(const protocol::AxisStatus& a) {
  if (a.error) {
    std::printf("  %-6s %s\n", a.axis.c_str(), a.error->c_str());
    return;
  }
  std::printf("  %-6s %-11s %11.4f°  %s %s%s\n", a.axis.c_str(), a.mode.c_str(), a.angle_deg,
              a.enabled ? "enabled" : "disabled", a.homed ? "homed" : "not homed",
              a.fault_text.empty() ? "" : (" fault: " + a.fault_text).c_str());
}

void print_status(const protocol::StatusResult& s) {
  const protocol::DaemonInfo& d = s.daemon;
  std::printf("standcald %s (protocol %s), up %s, %lld client(s)\n", d.version.c_str(),
              d.protocol.c_str(), duration_text(d.uptime_s).c_str(),
              static_cast<long long>(d.clients));
  std::printf("backend: %s%s\n", s.backend.description.c_str(),
              s.backend.simulated ? "  (SIMULATED: not a real stand or unit)" : "");
  const protocol::StandStatus& st = s.stand;
  std::printf("stand %s (%s): %s%s\n", st.id.c_str(), st.name.c_str(), st.lifecycle.c_str(),
              st.estop_latched ? ", EMERGENCY STOP LATCHED" : "");
  for (const protocol::AxisStatus& a : st.axes) print_axis(a);
  std::printf("unit %s: %s, %llu samples, %llu incomplete\n", st.unit.name.c_str(),
              st.unit.silent ? "SILENT" : "talking",
              static_cast<unsigned long long>(st.unit.samples),
              static_cast<unsigned long long>(st.unit.incomplete_samples));
  if (s.run) {
    std::printf("run %s: %s  %s\n", s.run->run_id.c_str(), s.run->state.c_str(),
                progress_line(*s.run).c_str());
  } else {
    std::printf("no run in progress\n");
  }
}

// The run's compensation, its checksum checked, as FILE.json and FILE.csv.
void export_compensation(const json& result, const std::string& run_id, const std::string& path) {
  if (!result.contains("compensation")) {
    throw std::runtime_error(
        "run " + run_id + " has no compensation: " +
        result.value("fit_error", std::string("a standcald older than compensation files "
                                              "fitted it; refit its recording with "
                                              "`standcal fit RECORDING --compensation FILE`")));
  }
  const Compensation c = compensation_from_json(result["compensation"]);
  const std::string stem = write_compensation(c, path);
  std::fprintf(stderr, "compensation of run %s written to %s.json and %s.csv\n", run_id.c_str(),
               stem.c_str(), stem.c_str());
}

// What the daemon saw in a run's recording (a truncated line, g assumed, no Allan curve).
void print_recording_warnings(const json& r) {
  if (!r.contains("recording_warnings") || !r["recording_warnings"].is_array()) return;
  for (const json& w : r["recording_warnings"])
    if (w.is_string()) std::fprintf(stderr, "warning: %s\n", w.get<std::string>().c_str());
}

void print_result(const json& r) {
  // The same report as `standcal fit`, when the recording is readable here.
  const std::string path = r.value("recording_path", "");
  bool printed = false;
  try {
    const Recording rec = read_recording(path);
    AveragedRecording averaged = average_recording(rec);
    FitNoiseOptions noise;
    // As the daemon: the run's wander, its own long dwell's, or the bound or floor of its unit's
    // static recording (the header carries its curves or its floor) or of its own long dwell.
    take_unit_wander_with_static_recording(noise, rec, averaged.allan, nullptr);
    FitResult fit = fit_invariant_joint(averaged.averages, noise);
    fit.noise.allan = std::move(averaged.allan);
    std::cout << format_report(fit, report_context(rec, std::move(averaged.averages)));
    printed = true;
  } catch (const std::exception& e) {
    // Read elsewhere, or gone: the daemon's own figures below, and why not the full report.
    std::fprintf(stderr, "warning: the report needs the recording, which cannot be read here: %s\n",
                 e.what());
  }
  if (!printed && r.contains("fit_error")) {
    std::printf("no calibration from this run alone: %s\n", r.value("fit_error", "").c_str());
  } else if (!printed) {
    std::printf("estimator %s, %d positions, redundancy %d\n", r.value("estimator", "").c_str(),
                r.value("positions", 0), r.value("redundancy", 0));
    for (auto it = r["parameters"].begin(); it != r["parameters"].end(); ++it) {
      const json& p = it.value();
      if (p["value"].is_number()) {
        std::printf("  %-8s %12.3f ± %8.3f %s\n", it.key().c_str(), p["value"].get<double>(),
                    p["sigma"].is_number() ? p["sigma"].get<double>() : NAN,
                    p.value("unit", "").c_str());
      } else {
        std::printf("  %-8s not observable\n", it.key().c_str());
      }
    }
  }
  print_recording_warnings(r);
  const Traceability t = traceability_from_json(r.value("traceability", json::object()));
  std::printf("\nrun %s, unit %s, stand %s, operator %s\n", t.run_id.c_str(), t.unit_serial.c_str(),
              t.stand_id.c_str(), t.operator_name.c_str());
  std::printf("started %s, ended %s, standcal %s, config %s\n", t.started_utc.c_str(),
              t.ended_utc.c_str(), t.software_version.c_str(), t.config_hash.c_str());
  std::printf("g = %.6f m/s² (%s)\nrecording: %s\n", t.g_local_mps2, t.g_source.c_str(),
              path.c_str());
}

// Follows a run's events until it ends; returns its final state.
protocol::RunStatusResult run_status(protocol::Client& c, std::optional<std::string> run_id) {
  return call(c, protocol::method::run_status, protocol::RunTargetParams{std::move(run_id)})
      .get<protocol::RunStatusResult>();
}

// Follows a run's events until it ends; its final state.
std::string watch(protocol::Client& c, const std::string& run_id, bool as_json) {
  call(c, protocol::method::subscribe, protocol::SubscribeParams{});
  const bool tty = ::isatty(STDOUT_FILENO) != 0 && !as_json;
  std::string state = run_status(c, run_id).state;
  if (terminal_state(state)) return state;
  std::string last_line;
  for (;;) {
    auto n = c.next_notification(2s);
    if (!n) {
      state = run_status(c, run_id).state;  // a quiet phase: poll
      if (terminal_state(state)) return state;
      continue;
    }
    const json& p = (*n)["params"];
    if (p.value("run_id", run_id) != run_id) continue;
    const std::string event = (*n)["method"];
    if (as_json) {
      std::cout << n->dump() << std::endl;
    } else if (event == protocol::event::run_progress) {
      const auto progress = p.get<protocol::RunProgress>();
      const std::string line = progress_line(progress);
      if (tty) {
        std::printf("\r%-78s", line.c_str());
        std::fflush(stdout);
      } else if (line != last_line && progress.phase == "sampling") {
        std::printf("%s\n", line.c_str());
      }
      last_line = line;
    } else if (event == protocol::event::run_state) {
      const auto change = p.get<protocol::RunStateEvent>();
      if (tty) std::printf("\n");
      std::printf("run %s: %s%s\n", run_id.c_str(), change.state.c_str(),
                  change.reason.empty() ? "" : (" — " + change.reason).c_str());
      if (terminal_state(change.state)) return change.state;
    } else if (event == protocol::event::fault) {
      if (tty) std::printf("\n");
      std::printf("fault: %s\n", p.get<protocol::FaultEvent>().message.c_str());
    }
  }
}

// The answer of run pause/abort/resume/confirm/status, in a line.
void print_run_answer(const std::string& method, const json& r) {
  if (method == protocol::method::run_status) {
    const auto s = r.get<protocol::RunStatusResult>();
    std::printf("run %s: %s  %s\n", s.run_id.c_str(), s.state.c_str(), progress_line(s).c_str());
  } else if (method == protocol::method::operator_confirm) {
    std::printf("run %s: confirmed\n", r.get<protocol::ConfirmedResult>().run_id.c_str());
  } else if (r.contains("state")) {
    const auto s = r.get<protocol::RunStateResult>();
    std::printf("run %s: %s\n", s.run_id.c_str(), s.state.c_str());
  } else {  // run.resume of a stored run
    const auto s = r.get<protocol::RunResumed>();
    std::printf("run %s: resumed at position %d/%d\n", s.run_id.c_str(), s.position, s.positions);
  }
}

struct DiagnoseArgs {
  std::string run_id, report, op;
  bool run_proposed = false;
  double dwell_s = -1, settle_s = -1;
};

void print_diagnosis(const json& d) {
  std::printf("run %s: verdict %s\n", d.value("run_id", "").c_str(),
              d.value("verdict", "?").c_str());
  for (const json& s : d.value("summary", json::array()))
    std::printf("  %s\n", s.get<std::string>().c_str());
  std::printf("where:\n");
  for (const json& s : d.value("located", json::array()))
    std::printf("  %s\n", s.get<std::string>().c_str());
  for (const json& p : d.value("proposed_positions", json::array()))
    std::printf("proposed position: alpha1 %.0f deg, alpha2 %.0f deg (%s)\n",
                p.value("alpha1_deg", 0.0), p.value("alpha2_deg", 0.0), p.value("why", "").c_str());
  print_recording_warnings(d);
}

// "The daemon can run those positions on request": the proposed positions as an inline
// programme on the same unit and mount, named after the run they follow.
protocol::RunStartParams follow_up_params(const json& d, const DiagnoseArgs& a) {
  const json& proposed = d["proposed_positions"];
  if (!proposed.is_array() || proposed.empty()) {
    throw std::runtime_error("run " + a.run_id + ": the diagnosis (verdict " +
                             d.value("verdict", "?") +
                             ") proposes no positions, so there is no follow-up run to start");
  }
  json positions = json::array();
  for (const json& p : proposed)
    positions.push_back({{"alpha1_deg", p["alpha1_deg"]},
                         {"alpha2_deg", p["alpha2_deg"]},
                         {"mount", d.value("mount", "x")}});
  protocol::RunStartParams params;
  params.program = {{"name", "follow-up of " + a.run_id}, {"positions", positions}};
  params.unit_serial = d.value("unit_serial", "");
  if (a.dwell_s > 0) params.dwell_s = a.dwell_s;
  if (a.settle_s >= 0) params.settle_s = a.settle_s;
  if (!a.op.empty()) params.operator_name = a.op;
  // Same unit, same type: the follow-up's certificate applies the same limits.
  if (const std::string unit_type = d.value("unit_type", ""); !unit_type.empty())
    params.unit_type = unit_type;
  return params;
}

void run_diagnose(const DaemonOptions& o, const DiagnoseArgs& a) {
  const auto connection = connect_daemon(o);
  protocol::Client& c = *connection;
  const protocol::RunDiagnoseParams params{a.run_id, !a.report.empty()};
  // A diagnosis takes seconds (a long recording, a busy bench PC): wait generously.
  json d = call(c, protocol::method::run_diagnose, params, std::chrono::minutes(5));
  if (!a.report.empty()) {
    if (!d["report_html"].is_string())
      throw std::runtime_error("run " + a.run_id + ": " + d.value("report_note", "no report"));
    write_file_atomically(a.report, d["report_html"].get<std::string>(), "the report");
    std::fprintf(stderr, "report written to %s\n", a.report.c_str());
  }
  d.erase("report_html");
  json follow_up;
  if (a.run_proposed) follow_up = call(c, protocol::method::run_start, follow_up_params(d, a));
  if (o.json) {
    if (a.run_proposed) d["follow_up_run"] = follow_up;
    std::cout << json_text(d) << "\n";
    return;
  }
  print_diagnosis(d);
  if (a.run_proposed) {
    const auto started = follow_up.get<protocol::RunStarted>();
    std::printf("follow-up run %s started (%d positions); follow it with `standcal run watch %s`\n",
                started.run_id.c_str(), started.positions, started.run_id.c_str());
  }
}

void add_status(CLI::App& app) {
  auto o = std::make_shared<DaemonOptions>();
  auto* cmd = app.add_subcommand("status", "standcald, stand, unit and run at a glance");
  add_daemon_options(cmd, *o);
  cmd->callback([o] {
    const auto connection = connect_daemon(*o);
    protocol::Client& c = *connection;
    const json s = call(c, protocol::method::status);
    if (o->json) {
      std::cout << json_text(s) << "\n";
    } else {
      print_status(s.get<protocol::StatusResult>());
    }
  });
}

void add_estop(CLI::App& app) {
  auto o = std::make_shared<DaemonOptions>();
  auto* cmd = app.add_subcommand("estop", "EMERGENCY STOP: stop and disable both axes now");
  add_daemon_options(cmd, *o);
  auto reset_flag = std::make_shared<bool>(false);
  cmd->add_flag("--reset", *reset_flag, "clear a latched emergency stop instead");
  cmd->callback([o, reset_flag] {
    const auto connection = connect_daemon(*o, 5s);
    protocol::Client& c = *connection;
    const json r = call(c, *reset_flag ? protocol::method::estop_reset : protocol::method::estop,
                        json::object(), 10s);
    if (o->json) {
      std::cout << json_text(r) << "\n";
    } else {
      std::printf("%s\n", r.get<protocol::EstopResult>().message.c_str());
    }
  });
}

struct RunsArgs {
  std::string unit, before;
  int limit = 0;  // 0: the daemon's default page size
  bool all = false;
};

protocol::RunsListParams runs_list_params(const RunsArgs& a, const std::string& before) {
  protocol::RunsListParams p;
  if (!a.unit.empty()) p.unit_serial = a.unit;
  if (!before.empty()) p.before = before;
  if (a.limit > 0) {
    p.limit = a.limit;
  } else if (a.all) {
    p.limit = protocol::runs_list_max_limit;
  }
  return p;
}

protocol::RunsPage runs_page(protocol::Client& c, const RunsArgs& a, const std::string& before) {
  return call(c, protocol::method::runs_list, runs_list_params(a, before))
      .get<protocol::RunsPage>();
}

// One page, or with --all every page (each answer stays bounded; the CLI joins them).
protocol::RunsPage list_runs(protocol::Client& c, const RunsArgs& a) {
  protocol::RunsPage page = runs_page(c, a, a.before);
  if (!a.all) return page;
  protocol::RunsPage all{std::move(page.runs), false};
  while (page.more && !all.runs.empty()) {
    page = runs_page(c, a, all.runs.back().run_id);
    all.runs.insert(all.runs.end(), page.runs.begin(), page.runs.end());
  }
  return all;
}

void print_runs(const protocol::RunsPage& r, const RunsArgs& a) {
  if (r.runs.empty()) std::printf("no runs\n");
  for (const protocol::RunListEntry& x : r.runs) {
    std::printf("%-32s %-10s %-10s %-12s %2d/%-2d %s%s\n", x.run_id.c_str(), x.unit_serial.c_str(),
                x.program.c_str(), x.state.c_str(), x.positions_done, x.positions,
                x.started_utc.c_str(), x.has_result ? "  result" : "");
  }
  if (r.more && !r.runs.empty()) {
    const std::string unit = a.unit.empty() ? "" : " --unit-serial " + a.unit;
    std::printf("(older runs: standcal runs%s --before %s, or --all)\n", unit.c_str(),
                r.runs.back().run_id.c_str());
  }
}

void add_runs(CLI::App& app) {
  auto o = std::make_shared<DaemonOptions>();
  auto a = std::make_shared<RunsArgs>();
  auto* cmd = app.add_subcommand("runs", "the daemon's runs, newest first, one page at a time");
  add_daemon_options(cmd, *o);
  cmd->add_option("--unit-serial,--unit", a->unit, "only this unit's runs");
  cmd->add_option("--before", a->before, "only runs older than this run id (the next page)");
  cmd->add_option("--limit", a->limit,
                  "runs per page (default: the daemon's, 100; with --all, 1000)")
      ->check(CLI::Range(1, protocol::runs_list_max_limit));
  cmd->add_flag("--all", a->all, "every run, fetched page by page");
  cmd->callback([o, a] {
    const auto connection = connect_daemon(*o);
    const protocol::RunsPage r = list_runs(*connection, *a);
    if (o->json) {
      std::cout << json_text(json(r)) << "\n";
    } else {
      print_runs(r, *a);
    }
  });
}

// --dwell-s and --settle-s of a run (--dwell and --settle, their older spellings, still
// work); left at -1, the daemon's configured times apply.
void add_run_timing_options(CLI::App* cmd, double& dwell_s, double& settle_s,
                            const std::string& which_run) {
  cmd->add_option("--dwell-s,--dwell", dwell_s,
                  which_run + "seconds of samples per position (default: the daemon's)")
      ->check(cli_checks::kPositive);
  cmd->add_option("--settle-s,--settle", settle_s,
                  which_run + "seconds to settle after in-position (default: the daemon's)")
      ->check(cli_checks::kNonNegative);
}

void add_run(CLI::App& app) {
  auto* run = app.add_subcommand("run", "calibration runs on standcald");
  run->require_subcommand(1);

  auto so = std::make_shared<DaemonOptions>();
  struct StartArgs {
    std::string program, unit, unit_type, op;
    double dwell_s = -1, settle_s = -1, warmup_s = -1;
    bool wait = false;
  };
  auto sa = std::make_shared<StartArgs>();
  auto* start =
      run->add_subcommand("start", "start a run: PROGRAM is paper9, classic24 or a library name");
  add_daemon_options(start, *so);
  start->add_option("program", sa->program, "paper9 | classic24 | a library name")->required();
  start->add_option("--unit-serial,--unit", sa->unit, "serial number of the unit on the stand")
      ->required();
  start->add_option("--unit-type", sa->unit_type,
                    "the unit's type: which acceptance limits its certificate uses");
  add_run_timing_options(start, sa->dwell_s, sa->settle_s, "");
  start
      ->add_option("--warmup-s", sa->warmup_s,
                   "hold the first position this long before its dwell, the unit's warm-up: "
                   "recorded, left out of its mean, fed to the noise model (default: the "
                   "programme's, else none)")
      ->check(cli_checks::number_within(0, true, kMaxDwell_s));
  start->add_option("--operator", sa->op, "who runs it, for traceability");
  start->add_flag("--wait", sa->wait,
                  "follow the run with a live progress line; print the report at the end");
  start->callback([so, sa] {
    const auto connection = connect_daemon(*so);
    protocol::Client& c = *connection;
    protocol::RunStartParams params;
    params.program = sa->program;
    params.unit_serial = sa->unit;
    if (!sa->unit_type.empty()) params.unit_type = sa->unit_type;
    if (sa->dwell_s > 0) params.dwell_s = sa->dwell_s;
    if (sa->settle_s >= 0) params.settle_s = sa->settle_s;
    if (sa->warmup_s >= 0) params.warmup_s = sa->warmup_s;
    if (!sa->op.empty()) params.operator_name = sa->op;
    const json r = call(c, protocol::method::run_start, params);
    const auto started = r.get<protocol::RunStarted>();
    const std::string& id = started.run_id;
    if (!sa->wait) {
      if (so->json) {
        std::cout << json_text(r) << "\n";
      } else {
        std::printf("run %s started (%d positions); follow it with `standcal run watch`\n",
                    id.c_str(), started.positions);
      }
      return;
    }
    if (!so->json) std::printf("run %s started (%d positions)\n", id.c_str(), started.positions);
    const std::string state = watch(c, id, so->json);
    if (state != "done") throw std::runtime_error("run " + id + " ended " + state);
    const json result = call(c, protocol::method::run_result, protocol::RunResultParams{id});
    if (so->json) {
      std::cout << json_text(result) << "\n";
    } else {
      print_result(result);
    }
  });

  auto wo = std::make_shared<DaemonOptions>();
  auto watch_id = std::make_shared<std::string>();
  auto* watch_cmd = run->add_subcommand("watch", "follow the current (or given) run until it ends");
  add_daemon_options(watch_cmd, *wo);
  watch_cmd->add_option("run_id", *watch_id, "run id (default: the current or newest run)");
  watch_cmd->callback([wo, watch_id] {
    const auto connection = connect_daemon(*wo);
    protocol::Client& c = *connection;
    const auto s = run_status(c, watch_id->empty() ? std::nullopt : std::optional(*watch_id));
    const std::string state = watch(c, s.run_id, wo->json);
    if (!wo->json) std::printf("run %s is %s\n", s.run_id.c_str(), state.c_str());
  });

  auto ro = std::make_shared<DaemonOptions>();
  auto result_id = std::make_shared<std::string>();
  auto compensation_path = std::make_shared<std::string>();
  auto* result = run->add_subcommand("result", "the calibration of a finished run");
  add_daemon_options(result, *ro);
  result->add_option("run_id", *result_id, "run id (see `standcal runs`)")->required();
  result->add_option("--compensation", *compensation_path,
                     "also write the run's compensation as FILE.json and FILE.csv");
  result->callback([ro, result_id, compensation_path] {
    const auto connection = connect_daemon(*ro);
    protocol::Client& c = *connection;
    const json r = call(c, protocol::method::run_result, protocol::RunResultParams{*result_id});
    if (!compensation_path->empty()) export_compensation(r, *result_id, *compensation_path);
    if (ro->json) {
      std::cout << json_text(r) << "\n";
    } else {
      print_result(r);
    }
  });

  auto dgo = std::make_shared<DaemonOptions>();
  auto da = std::make_shared<DiagnoseArgs>();
  auto* diagnose = run->add_subcommand(
      "diagnose", "where a run's recording and the model disagree (docs/diagnosis.md)");
  add_daemon_options(diagnose, *dgo);
  diagnose->add_option("run_id", da->run_id, "run id (see `standcal runs`)")->required();
  diagnose->add_option("--report", da->report,
                       "write the HTML report with plots to FILE (docs/report.md)");
  diagnose->add_flag("--run-proposed", da->run_proposed,
                     "start a follow-up run of the proposed positions on the same unit");
  add_run_timing_options(diagnose, da->dwell_s, da->settle_s, "follow-up run: ");
  diagnose->add_option("--operator", da->op, "follow-up run: who runs it, for traceability");
  diagnose->callback([dgo, da] { run_diagnose(*dgo, *da); });

  // Simple control commands: one call, print the answer.
  struct Simple {
    const char* name;
    const char* method;
    const char* help;
  };
  for (const Simple& s :
       {Simple{"resume", protocol::method::run_resume,
               "resume a paused, interrupted or faulted run"},
        Simple{"pause", protocol::method::run_pause, "pause the run; the stand stops"},
        Simple{"abort", protocol::method::run_abort, "abort the run; recorded positions are kept"},
        Simple{"confirm", protocol::method::operator_confirm, "confirm a re-mount step is done"},
        Simple{"status", protocol::method::run_status,
               "state and progress of the current (or given) run"}}) {
    auto o = std::make_shared<DaemonOptions>();
    auto id = std::make_shared<std::string>();
    auto* cmd = run->add_subcommand(s.name, s.help);
    add_daemon_options(cmd, *o);
    cmd->add_option("run_id", *id, "run id (default: the current or newest resumable run)");
    const std::string method = s.method;
    cmd->callback([o, id, method] {
      const auto connection = connect_daemon(*o);
      protocol::Client& c = *connection;
      const json r = call(
          c, method, protocol::RunTargetParams{id->empty() ? std::nullopt : std::optional(*id)});
      if (o->json) {
        std::cout << json_text(r) << "\n";
      } else {
        print_run_answer(method, r);
      }
    });
  }
}

void add_daemon_commands(CLI::App& app) {
  add_status(app);
  add_run(app);
  add_estop(app);
  add_runs(app);
}

}  // namespace

static const bool run_commands_registered = register_command_group(add_daemon_commands);

}  // namespace standcal::cli
