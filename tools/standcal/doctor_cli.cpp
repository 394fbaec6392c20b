// `standcal doctor`: is this bench PC ready to calibrate? One PASS/FAIL line per check —
// the configuration, the state directory, the daemon's socket, the stand link, the unit,
// the records database — each failure with what to do about it (docs/install.md).
// With the daemon running, the stand and the unit are judged from its status (the daemon
// owns the serial port and the CAN socket); without it, they are opened as the daemon
// would open them (daemon/standcald/hardware.hpp).
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "calib/json_text.hpp"
#include "daemon/standcald/config.hpp"
#include "daemon/standcald/hardware.hpp"
#include "drivers/modbus/register_map.hpp"
#include "protocol/jsonrpc/client.hpp"
#include "protocol/jsonrpc/messages.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "protocol/jsonrpc/paths.hpp"
#include "records/db/records_db.hpp"
#include "tools/standcal/commands.hpp"

namespace standcal::cli {
namespace {

using nlohmann::json;

struct DoctorOptions {
  std::string config = paths::kConfigFile;
  double sample_s = 1.0;  // how long the unit's frames are counted
  bool json = false;
};

// skip: not judged here, and not a failure (said why in the detail). warn: works, but not as
// a bench engineer would want it (said what to change in the detail); not a failure either.
enum class Verdict { pass, warn, fail, skip };

struct CheckLine {
  std::string check;
  Verdict verdict = Verdict::fail;
  std::string detail;  // what was found
  std::string fix;     // on a failure: what to do
};

const char* verdict_word(Verdict v) {
  switch (v) {
    case Verdict::pass:
      return "PASS";
    case Verdict::warn:
      return "WARN";
    case Verdict::fail:
      return "FAIL";
    case Verdict::skip:
      return "SKIP";
  }
  return "?";
}

class Doctor {
 public:
  explicit Doctor(DoctorOptions o) : o_(std::move(o)) {}

  std::vector<CheckLine> run() {
    if (!check_config()) return lines_;
    guarded("stand timing", [this] { check_stand_timing(); });
    guarded("state directory", [this] { check_state_dir(); });
    std::optional<protocol::StatusResult> status;
    guarded("daemon", [this, &status] { status = check_daemon(); });
    if (status) {
      guarded("stand link", [this, &status] { check_stand_in_daemon(*status); });
      guarded("unit", [this] { check_unit_in_daemon(); });
    } else if (daemon_certainly_down()) {
      guarded("stand link", [this] { check_hardware_directly(); });
    } else {
      // The socket is there but did not answer us (permissions, a busy daemon): the daemon
      // may hold the serial port and the CAN socket, and a second Modbus master on its
      // RS-485 line would corrupt its frames.
      for (const char* check : {"stand link", "unit"})
        skip(check,
             "not opened: the daemon's socket exists, so it may be running and hold the hardware");
    }
    guarded("records database", [this] { check_records_db(); });
    return lines_;
  }

 private:
  void pass(const std::string& check, const std::string& detail) {
    lines_.push_back({check, Verdict::pass, detail, ""});
  }
  void warn(const std::string& check, const std::string& detail) {
    lines_.push_back({check, Verdict::warn, detail, ""});
  }
  void skip(const std::string& check, const std::string& detail) {
    lines_.push_back({check, Verdict::skip, detail, ""});
  }
  void fail(const std::string& check, const std::string& detail, const std::string& fix) {
    lines_.push_back({check, Verdict::fail, detail, fix});
  }

  // One check that throws (a directory it may not read) is one FAIL line, not the end of
  // the report.
  template <class Check>
  void guarded(const std::string& name, Check check) {
    try {
      check();
    } catch (const std::exception& e) {
      fail(name, e.what(),
           "see the message; run doctor as root or as a member of group standcal to see more");
    }
  }

  // No daemon listens: the socket file is absent, or nothing accepts on it (a stale file).
  bool daemon_certainly_down() const {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return false;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", config_.socket_path.c_str());
    const int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
    const int connect_errno = errno;
    ::close(fd);
    return rc != 0 && (connect_errno == ENOENT || connect_errno == ECONNREFUSED);
  }

  bool check_config() {
    try {
      config_ = daemon::load_config(o_.config);
      daemon::require_named_backends(config_);
    } catch (const std::exception& e) {
      fail("config", e.what(),
           "fix the file (man 5 standcald.json), or give the right one with --config");
      return false;
    }
    pass("config",
         o_.config + ": stand " + config_.stand_backend + ", unit " + config_.unit_backend);
    return true;
  }

  // The Modbus stand's register map and link timing, read as the daemon reads them: a file
  // that does not parse fails here, before the daemon's start would; a timing whose retries
  // outlast the controller's heartbeat watchdog, or a watchdog switched off, is a WARN
  // (drivers/modbus/register_map.hpp).
  void check_stand_timing() {
    if (config_.stand_backend != "modbus") return;
    const std::string& path = config_.modbus_map_file;
    const std::string where = config_.source + ": stand.register_map" +
                              (path.empty() ? " (not given: the defaults)" : "");
    const auto map = drivers::modbus::load_config(path);
    if (!map) {
      fail("stand timing", where + ": " + map.status().message,
           "fix the file (docs/stand-modbus.md, \"Config keys\")");
      return;
    }
    const std::vector<std::string> warnings =
        drivers::modbus::unattended_warnings(map.value(), path);
    for (const std::string& w : warnings) warn("stand timing", where + ": " + w);
    if (!warnings.empty()) return;
    const drivers::modbus::LinkTiming& t = map.value().timing;
    char text[256];
    std::snprintf(text, sizeof text,
                  ": a request retried %d times at %g s after a %g s heartbeat period holds the "
                  "heartbeat for at most %g s, within the %g s watchdog",
                  t.tries, t.timeout_s, t.heartbeat_period_s, drivers::modbus::heartbeat_held_s(t),
                  t.heartbeat_timeout_s);
    pass("stand timing", where + text);
  }

  void check_state_dir() {
    const std::string& dir = config_.state_dir;
    struct stat st {};
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
      fail("state directory", dir + " does not exist",
           "install the package (its tmpfiles.d entry creates it), or `systemd-tmpfiles --create "
           "standcal.conf`");
      return;
    }
    struct statvfs fs {};
    if (::statvfs(dir.c_str(), &fs) != 0) {
      fail("state directory", dir + ": cannot read its free space", "check the file system");
      return;
    }
    const double free_gib = static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize) /
                            (1024.0 * 1024 * 1024);
    char text[160];
    std::snprintf(text, sizeof text,
                  "%s: %.1f GiB free (a 1-hour run at 100 Hz records about 40 MB)", dir.c_str(),
                  free_gib);
    if (free_gib < kMinFreeGib) {
      fail("state directory", text, "free space on its file system, or move state_dir");
      return;
    }
    pass("state directory", text);
  }

  // The daemon's status, or nothing when it does not answer (said as a failure).
  std::optional<protocol::StatusResult> check_daemon() {
    const std::string& socket = config_.socket_path;
    try {
      client_ = std::make_unique<protocol::Client>(socket, std::chrono::seconds(5));
      const auto status = client_->call(protocol::method::status).get<protocol::StatusResult>();
      const bool control = status.daemon.access.control;
      const protocol::BackendInfo& backend = status.backend;
      // (Empty: a daemon too old to say which backends it drives.)
      if ((!backend.stand.empty() && backend.stand != config_.stand_backend) ||
          (!backend.unit.empty() && backend.unit != config_.unit_backend)) {
        fail("daemon",
             "standcald on " + socket + " drives " + backend.description + ", but " + o_.config +
                 " names stand " + config_.stand_backend + " and unit " + config_.unit_backend,
             "restart it without --sim (`systemctl restart standcald`), or check that --config is "
             "the file it runs");
        return status;
      }
      pass(
          "daemon",
          "standcald " + status.daemon.version + " answers on " + socket + "; this user " +
              (control ? "may command the stand" : "may only watch (not in access.control_group)"));
      return status;
    } catch (const std::exception& e) {
      fail("daemon", socket + ": " + e.what(),
           "start it (`systemctl start standcald`), or run as a member of the socket's group; the "
           "stand and the unit are opened here only when no daemon listens on the socket");
      return std::nullopt;
    }
  }

  // What is wrong with one axis, in the words of both checks ("" when nothing).
  static std::string axis_problems(const std::string& axis, bool stopped_by_heartbeat,
                                   int fault_code, const std::string& fault_text) {
    std::string problems;
    if (stopped_by_heartbeat) problems += axis + ": stopped by a lost heartbeat; ";
    if (fault_code != 0) problems += axis + ": fault " + fault_text + "; ";
    return problems;
  }

  void check_stand_in_daemon(const protocol::StatusResult& status) {
    const protocol::StandStatus& stand = status.stand;
    if (stand.lifecycle == "unconfigured") {
      skip("stand link",
           stand.name +
               ": the daemon opens the link at its first stand or run command; stop the daemon "
               "and run doctor again to have the link opened here");
      return;
    }
    std::string problems;
    for (const protocol::AxisStatus& axis : stand.axes) {
      if (axis.error) problems += axis.axis + ": " + *axis.error + "; ";
      problems +=
          axis_problems(axis.axis, axis.stopped_by_heartbeat, axis.fault_code, axis.fault_text);
    }
    const std::string where = stand.name + " (" + stand.lifecycle + ")";
    if (stand.estop_latched) problems += "emergency stop latched; ";
    if (!problems.empty()) {
      fail("stand link", where + ": " + problems,
           "check the stand controller, its cable and stand.url; `standcal estop --reset` clears a "
           "latched stop");
      return;
    }
    pass("stand link", where + ": both axes read");
  }

  void check_unit_in_daemon() {
    try {
      const std::uint64_t before = unit_samples();
      const auto t0 = std::chrono::steady_clock::now();
      std::this_thread::sleep_for(std::chrono::duration<double>(o_.sample_s));
      const std::uint64_t after = unit_samples();
      const double elapsed_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (after == before) {
        skip("unit",
             "the daemon samples the unit only during a run; stop the daemon and run doctor again "
             "to have "
             "the unit's frames counted here");
        return;
      }
      judge_rate(static_cast<double>(after - before) / elapsed_s, "through the daemon");
    } catch (const std::exception& e) {
      fail("unit", e.what(), "check the daemon");
    }
  }

  std::uint64_t unit_samples() {
    const protocol::UnitStatus unit =
        client_->call(protocol::method::status).get<protocol::StatusResult>().stand.unit;
    if (unit.silent) throw std::runtime_error(unit.name + " is silent");
    return unit.samples;
  }

  void judge_rate(double rate_hz, const std::string& how) {
    char text[200];
    std::snprintf(text, sizeof text, "%.1f Hz %s (configured %.1f Hz)", rate_hz, how.c_str(),
                  config_.sample_rate_hz);
    if (std::abs(rate_hz - config_.sample_rate_hz) > 0.1 * config_.sample_rate_hz) {
      fail("unit", text,
           rate_hz == 0
               ? "no CAN frames arrive: check the unit's power, the bus (`ip -details link show`) "
                 "and unit.interface"
               : "set unit.sample_rate_hz to the unit's rate, or check for lost frames");
      return;
    }
    pass("unit", text);
  }

  // The daemon is not running: open the stand and the unit as it would, each on its own
  // (the other one simulated), so a unit that cannot be opened does not hide the stand.
  void check_hardware_directly() {
    daemon::DaemonConfig stand_only = config_;
    stand_only.unit_backend = "sim";
    if (auto hw = hardware_for("stand link", stand_only)) check_stand_directly(*hw->stand);
    daemon::DaemonConfig unit_only = config_;
    unit_only.stand_backend = "sim";
    if (auto hw = hardware_for("unit", unit_only)) check_unit_directly(*hw->unit);
  }

  std::optional<daemon::Hardware> hardware_for(const std::string& check,
                                               const daemon::DaemonConfig& config) {
    try {
      return daemon::make_hardware(config);
    } catch (const std::exception& e) {
      fail(check, e.what(),
           check == "unit" ? "check unit.interface and that the CAN interface exists and is up"
                           : "check stand.url and that the serial port or host exists");
      return std::nullopt;
    }
  }

  void check_stand_directly(drivers::Stand& stand) {
    if (const drivers::Status s = stand.configure(); !s) {
      fail("stand link", stand.name() + ": " + s.message,
           "check the stand controller, its cable and stand.url");
      return;
    }
    std::string problems;
    if (stand.lifecycle() == drivers::Lifecycle::error)
      problems += "the link is in error (an emergency stop latched?); ";
    for (const drivers::StandAxis axis : {drivers::StandAxis::outer, drivers::StandAxis::inner}) {
      const auto state = stand.read_state(axis);
      if (!state) {
        fail("stand link", stand.name() + ": " + state.status().message,
             "check the stand controller");
        (void)stand.cleanup();  // the finding is the read error; closing has nothing to add
        return;
      }
      const drivers::AxisState& st = state.value();
      if (st.estop)
        problems += std::string(drivers::to_string(axis)) + ": emergency stop latched; ";
      problems += axis_problems(drivers::to_string(axis), st.stopped_by_heartbeat, st.fault_code,
                                st.fault_text);
    }
    (void)stand.cleanup();  // an inactive or error stand always closes
    if (!problems.empty()) {
      fail("stand link", stand.name() + ": " + problems,
           "check the stand controller; `standcal stand --url URL reset` clears its latched stop");
      return;
    }
    pass("stand link", stand.name() + ": the controller answered, both axes read");
  }

  void check_unit_directly(drivers::AccelUnit& unit) {
    if (const drivers::Status s = unit.start(); !s) {
      fail("unit", unit.name() + ": " + s.message,
           "check unit.interface and that the CAN interface is up");
      return;
    }
    const auto samples = unit.collect(o_.sample_s);
    (void)unit.stop();  // the finding is the collect's; stopping cannot fail in either backend
    if (!samples) {
      fail("unit", unit.name() + ": " + samples.status().message,
           "no CAN frames arrive: check the unit's power, the bus and unit.interface");
      return;
    }
    judge_rate(static_cast<double>(samples.value().size()) / o_.sample_s, "on " + unit.name());
  }

  void check_records_db() {
    const std::string url =
        config_.db_url.empty() ? records::default_db_url(config_.state_dir) : config_.db_url;
    const std::string default_file = config_.state_dir + "/records.sqlite";
    std::error_code ec;
    if (config_.db_url.empty() && !std::filesystem::exists(default_file, ec) && !ec) {
      pass("records database",
           default_file + " does not exist yet: the daemon creates it at its first run");
      return;
    }
    try {
      auto db = records::open_records_db(url, records::OpenMode::existing);
      pass("records database",
           db->location() + " (schema version " + std::to_string(db->schema_version()) + ")");
    } catch (const std::exception& e) {
      fail("records database", e.what(),
           "an SQLite database is created by the daemon's first run; for PostgreSQL check the "
           "server and db");
    }
  }

  static constexpr double kMinFreeGib = 1.0;
  DoctorOptions o_;
  daemon::DaemonConfig config_;
  std::unique_ptr<protocol::Client> client_;
  std::vector<CheckLine> lines_;
};

void print(const std::vector<CheckLine>& lines, bool as_json) {
  if (as_json) {
    json out = json::array();
    for (const CheckLine& l : lines)
      out.push_back({{"check", l.check},
                     {"verdict", verdict_word(l.verdict)},
                     {"detail", l.detail},
                     {"fix", l.fix}});
    std::cout << json_text(out) << "\n";
    return;
  }
  for (const CheckLine& l : lines) {
    std::printf("%s  %-17s %s\n", verdict_word(l.verdict), l.check.c_str(), l.detail.c_str());
    if (l.verdict == Verdict::fail) std::printf("      %-17s -> %s\n", "", l.fix.c_str());
  }
}

void add_doctor_command(CLI::App& app) {
  auto o = std::make_shared<DoctorOptions>();
  auto* cmd = app.add_subcommand(
      "doctor", "check this bench PC: config, state directory, daemon, stand, unit, records");
  cmd->add_option("--config", o->config, "the daemon's configuration")->capture_default_str();
  cmd->add_option("--sample-s", o->sample_s, "how long to count the unit's samples")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 60.0));
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->callback([o] {
    const std::vector<CheckLine> lines = Doctor(*o).run();
    print(lines, o->json);
    for (const CheckLine& l : lines)
      if (l.verdict == Verdict::fail) set_exit_code(ExitCode::runtime_error);
  });
}

const bool doctor_command_registered = register_command_group(add_doctor_command);

}  // namespace
}  // namespace standcal::cli
