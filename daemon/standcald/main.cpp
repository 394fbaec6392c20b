// standcald: the calibration service. `standcald --config FILE`, or for demos and tests
// `standcald --sim --socket PATH --state-dir DIR [--time-scale K]` (docs/daemon.md).
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <utility>

#include "daemon/standcald/config.hpp"
#include "daemon/standcald/diagnose_worker.hpp"
#include "daemon/standcald/hardware.hpp"
#include "daemon/standcald/records_sink.hpp"
#include "daemon/standcald/run_store.hpp"
#include "daemon/standcald/sequencer.hpp"
#include "daemon/standcald/server.hpp"
#include "protocol/jsonrpc/exit_codes.hpp"
#include "protocol/jsonrpc/text.hpp"
#include "standcal/version.hpp"

namespace {

struct Options {
  std::string config_file;
  bool sim = false;
  std::string socket_path;
  std::string state_dir;
  double time_scale = 1;
  int tcp_port = -1;
  std::string log_level;
};

standcal::daemon::DaemonConfig effective_config(const Options& o) {
  using namespace standcal::daemon;
  if (o.config_file.empty() && !o.sim) {
    throw ConfigError("give --config FILE (the installed one is " +
                      std::string(standcal::paths::kConfigFile) +
                      "), or --sim --socket PATH --state-dir DIR for the simulated backend");
  }
  DaemonConfig c =
      o.config_file.empty()
          ? sim_config(o.socket_path.empty() ? standcal::paths::kSocket : o.socket_path,
                       o.state_dir.empty() ? standcal::paths::kStateDir : o.state_dir, o.time_scale)
          : load_config(o.config_file);
  // Command-line values override the file (handy for a quick test of a lab config).
  if (!o.config_file.empty()) {
    if (!o.socket_path.empty()) c.socket_path = o.socket_path;
    if (!o.state_dir.empty()) c.state_dir = o.state_dir;
    if (o.sim) {
      c.stand_backend = c.unit_backend = "sim";
      c.stand_backend_named = c.unit_backend_named = true;
      c.sim.time_scale = o.time_scale;
    }
  }
  require_named_backends(c);
  // The paths go into run.json, result.json and the records database as JSON text: a byte
  // that is not UTF-8 made run.start fail with nlohmann's "type_error.316" (the config hash).
  for (const auto& [what, path] :
       {std::pair{"the state directory", c.state_dir}, std::pair{"the socket path", c.socket_path}})
    if (const auto problem = standcal::protocol::text_field_problem(path, 4096))
      throw ConfigError(std::string(what) + " '" + path + "' must " + *problem);
  if (o.tcp_port >= 0) {
    c.tcp_enabled = true;
    c.tcp_port = o.tcp_port;
  }
  if (!o.log_level.empty()) c.log_level = o.log_level;
  return c;
}

int run_daemon(const standcal::daemon::DaemonConfig& config) {
  using namespace standcal::daemon;
  spdlog::set_level(spdlog::level::from_str(config.log_level));
  // Block the shutdown signals in every thread: the server reads them from a signalfd.
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGTERM);
  sigaddset(&mask, SIGINT);
  pthread_sigmask(SIG_BLOCK, &mask, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  // A file-size limit (systemd LimitFSIZE=) must make a recording write fail with EFBIG,
  // which the run store reports, instead of killing the daemon mid-run.
  ::signal(SIGXFSZ, SIG_IGN);

  const StateDirLock state_lock(config.state_dir);  // before the store marks runs interrupted
  RunStore store(config.state_dir);
  Hardware hardware = make_hardware(config);
  spdlog::info("standcald {} starting: backend {}, state in {}", standcal::kVersion,
               hardware.description, config.state_dir);
  for (const std::string& warning : hardware.warnings) spdlog::warn("{}", warning);
  if (const auto& u = config.unit_static_recording) {
    spdlog::info("unit.static_recording: {}", unit_static_recording_words(*u));
    for (const std::string& warning : u->warnings) spdlog::warn("{}", warning);
  }
  // The records sink outlives the sequencer that feeds it; the recording and result.json
  // stay the source of truth, the database is filled from them (and retried).
  RecordsSink records(config.state_dir, config.db_url);
  records.start();
  Server* server_ptr = nullptr;
  Sequencer sequencer(config, std::move(hardware), store,
                      [&server_ptr, &records](const std::string& event, const nlohmann::json& p) {
                        records.on_event(event, p);
                        if (server_ptr != nullptr) server_ptr->publish(event, p);
                      });
  Server server(config, sequencer);
  server_ptr = &server;
  server.open_listeners();
  if (server.tcp_port() > 0) std::fprintf(stderr, "standcald: tcp port %d\n", server.tcp_port());
  sequencer.start();
  sd_notifyf(0, "READY=1\nSTATUS=listening on %s", config.socket_path.c_str());
  server.run();
  sd_notify(0, "STOPPING=1\nSTATUS=stopping the stand");
  sequencer.request_shutdown();
  sequencer.join();
  server_ptr = nullptr;
  spdlog::info("standcald stopped");
  return 0;
}

// Whether stderr is the journal (systemd sets JOURNAL_STREAM to its device:inode; a
// redirected stderr of a child keeps the variable but not the stream, so both are compared).
bool stderr_is_journal() {
  const char* stream = std::getenv("JOURNAL_STREAM");
  if (stream == nullptr) return false;
  unsigned long long dev = 0, ino = 0;
  if (std::sscanf(stream, "%llu:%llu", &dev, &ino) != 2) return false;
  struct stat st {};
  return ::fstat(STDERR_FILENO, &st) == 0 && st.st_dev == dev && st.st_ino == ino;
}

// Under systemd: the journal, with each message's priority and without our timestamp
// (journald stamps it). Elsewhere: stderr with a timestamp.
void set_up_logging() {
  if (stderr_is_journal()) {
    spdlog::set_default_logger(spdlog::systemd_logger_mt("standcald", "standcald"));
  } else {
    spdlog::set_default_logger(spdlog::stderr_color_mt("standcald"));
    spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e [%l] %v");
  }
}

}  // namespace

int main(int argc, char** argv) {
  // The child that computes one run.diagnose (diagnose_worker.hpp), not a daemon.
  if (argc == 2 && std::string(argv[1]) == standcal::daemon::kDiagnoseWorkerFlag)
    return standcal::daemon::diagnose_worker_main();
  set_up_logging();
  CLI::App app{"standcald: the standcal calibration service (JSON-RPC 2.0 over a Unix socket)"};
  app.set_version_flag("--version", standcal::kVersionLine);
  app.set_help_all_flag("--help-all", "Print this help and exit (for the man page)");
  app.footer(standcal::exit_code_table_text());
  Options o;
  app.add_option("--config", o.config_file, "configuration file (JSON; docs/daemon.md)");
  app.add_flag("--sim", o.sim, "use the simulated stand and unit");
  app.add_option("--socket", o.socket_path, "Unix socket path");
  app.add_option("--state-dir", o.state_dir, "state directory (recordings, run index)");
  app.add_option("--time-scale", o.time_scale, "simulated time runs this many times faster (--sim)")
      ->check(CLI::Range(0.01, 100000.0));
  app.add_option("--tcp-port", o.tcp_port,
                 "also listen on 127.0.0.1:PORT (0: any free port, printed)")
      ->check(CLI::Range(0, 65535));
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return standcal::parse_error_exit_status(app.exit(e));
  }
  try {
    return run_daemon(effective_config(o));
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    // The journal has it already; on a terminal, the plain line is the one to read.
    if (!stderr_is_journal()) std::fprintf(stderr, "standcald: %s\n", e.what());
    return standcal::exit_status(standcal::ExitCode::runtime_error);
  }
}
