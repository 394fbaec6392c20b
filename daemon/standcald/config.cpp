#include "daemon/standcald/config.hpp"

#include <arpa/inet.h>
#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "calib/text.hpp"

namespace standcal::daemon {

using nlohmann::json;

namespace {

// One JSON object of the config, read key by key; keys nobody read are errors (a typo
// must not silently fall back to a default).
class Section {
 public:
  Section(const json& j, std::string path, const std::string& source)
      : j_(j), path_(std::move(path)), source_(source) {
    if (!j_.is_object()) fail("", "must be a JSON object");
  }

  [[noreturn]] void fail(const std::string& key, const std::string& why) const {
    std::string where = path_;
    if (!key.empty()) where += (where.empty() ? "" : ".") + key;
    throw ConfigError(source_ + ": " + (where.empty() ? "top level" : where) + ": " + why);
  }

  const json* find(const std::string& key) {
    seen_.insert(key);
    auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }

  void number(const std::string& key, double& out, double min, double max) {
    const json* v = find(key);
    if (v == nullptr) return;
    if (!v->is_number()) fail(key, "must be a number");
    const double d = v->get<double>();
    if (!(d >= min && d <= max)) {
      fail(key, "must be between " + fmt(min) + " and " + fmt(max) + " (got " + fmt(d) + ")");
    }
    out = d;
  }
  void integer(const std::string& key, int& out, int min, int max) {
    double d = out;
    number(key, d, min, max);
    if (d != static_cast<double>(static_cast<int>(d))) fail(key, "must be a whole number");
    out = static_cast<int>(d);
  }
  void text(const std::string& key, std::string& out) {
    const json* v = find(key);
    if (v == nullptr) return;
    if (!v->is_string()) fail(key, "must be a string");
    // Config texts reach one-line places: the recording header (stand.id), paths, logs.
    if (const auto c = find_control_character(v->get_ref<const std::string&>())) {
      fail(key, "must be printable text on one line: it contains " + describe(*c));
    }
    out = v->get<std::string>();
  }
  // A key whose empty value would silently mean "none" (no group, no token): absent is
  // the way to say none, so a present but empty value is an error.
  void non_empty_text(const std::string& key, std::string& out, const std::string& omit_means) {
    const json* v = find(key);
    if (v == nullptr) return;
    text(key, out);
    if (out.empty()) fail(key, "must not be empty (leave the key out for " + omit_means + ")");
  }
  void choice(const std::string& key, std::string& out,
              std::initializer_list<const char*> allowed) {
    text(key, out);
    std::string list;
    for (const char* a : allowed) {
      if (out == a) return;
      list += std::string(list.empty() ? "" : ", ") + "\"" + a + "\"";
    }
    fail(key, "must be one of " + list + " (got \"" + out + "\")");
  }
  void flag(const std::string& key, bool& out) {
    const json* v = find(key);
    if (v == nullptr) return;
    if (!v->is_boolean()) fail(key, "must be true or false");
    out = v->get<bool>();
  }
  // A nested object, or nullptr when absent.
  std::unique_ptr<Section> sub(const std::string& key) {
    const json* v = find(key);
    if (v == nullptr) return nullptr;
    return std::make_unique<Section>(*v, path_.empty() ? key : path_ + "." + key, source_);
  }
  // Exactly, as the file wrote it: six digits said "must be between 0 and 3600 (got 3600)"
  // of 3600.0000001.
  static std::string fmt(double d) { return plain_round_trip_text(d); }
  void reject_unknown() const {
    for (auto it = j_.begin(); it != j_.end(); ++it) {
      if (!seen_.count(it.key())) fail(it.key(), "unknown key (see docs/daemon.md for the keys)");
    }
  }

 private:
  const json& j_;
  std::string path_;
  const std::string& source_;
  std::set<std::string> seen_;
};

void read_range(Section* s, AxisRange& r) {
  if (s == nullptr) return;
  s->flag("continuous", r.continuous);
  s->number("min_deg", r.min_deg, -3600, 3600);
  s->number("max_deg", r.max_deg, -3600, 3600);
  std::string wrap = r.cable_wrap == CableWrap::centred ? "centred" : "nearest";
  s->choice("cable_wrap", wrap, {"nearest", "centred"});
  r.cable_wrap = wrap == "centred" ? CableWrap::centred : CableWrap::nearest;
  if (!r.continuous && r.max_deg - r.min_deg < 1)
    s->fail("max_deg", "must exceed min_deg by at least 1 degree");
  s->reject_unknown();
}

// socket.mode: an octal string such as "0660" (JSON has no octal numbers, and a decimal
// 660 would silently mean something else).
void read_mode(Section& s, unsigned& mode) {
  std::string text;
  s.text("mode", text);
  if (text.empty()) return;
  if (text.size() > 4 || text.find_first_not_of("01234567") != std::string::npos) {
    s.fail("mode", "must be an octal string such as \"0660\" (got \"" + text + "\")");
  }
  mode = static_cast<unsigned>(std::stoul(text, nullptr, 8));
  if (mode > 0777) s.fail("mode", "must be at most \"0777\" (got \"" + text + "\")");
  if ((mode & 0600) != 0600)
    s.fail("mode", "must give the owner (the daemon's user) read and write (got \"" + text + "\")");
}

void read_tcp(Section& s, DaemonConfig& c) {
  s.flag("enabled", c.tcp_enabled);
  s.integer("port", c.tcp_port, 0, 65535);
  s.text("bind", c.tcp_bind);
  s.non_empty_text("token_file", c.tcp_token_file,
                   "no token: TCP clients may only read and send estop");
  in6_addr probe{};
  if (::inet_pton(AF_INET, c.tcp_bind.c_str(), &probe) != 1 &&
      ::inet_pton(AF_INET6, c.tcp_bind.c_str(), &probe) != 1) {
    s.fail("bind", "must be a numeric IPv4 or IPv6 address such as \"127.0.0.1\" (got \"" +
                       c.tcp_bind + "\")");
  }
  // Off loopback anyone on the network can connect: refuse to start without a token.
  if (c.tcp_enabled && !is_loopback_address(c.tcp_bind) && c.tcp_token_file.empty()) {
    s.fail("token_file", "is required when tcp.bind (" + c.tcp_bind +
                             ") is not a loopback address (docs/security.md)");
  }
  s.reject_unknown();
}

void read_server(Section& top, DaemonConfig& c) {
  if (auto s = top.sub("socket")) {
    s->text("path", c.socket_path);
    if (c.socket_path.empty()) s->fail("path", "must not be empty");
    s->non_empty_text("group", c.socket_group, "leaving the socket file's group alone");
    read_mode(*s, c.socket_mode);
    s->reject_unknown();
  }
  if (auto s = top.sub("tcp")) read_tcp(*s, c);
  if (auto s = top.sub("access")) {
    s->non_empty_text("control_group", c.control_group,
                      "no control group: every Unix-socket peer may command");
    s->reject_unknown();
  }
  top.integer("max_clients", c.max_clients, 256, 65536);
  double queue_bytes = static_cast<double>(c.client_queue_bytes);
  top.number("client_queue_bytes", queue_bytes, 65536, 1 << 30);
  c.client_queue_bytes = static_cast<std::size_t>(queue_bytes);
  top.number("client_request_timeout_s", c.client_request_timeout_s, 0.1, 3600);
  top.number("client_idle_timeout_s", c.client_idle_timeout_s, 0.1, 7 * 86400);
  top.text("state_dir", c.state_dir);
  if (c.state_dir.empty()) top.fail("state_dir", "must not be empty");
  // Only the URL's form is checked here: a shared PostgreSQL server may be down while
  // the daemon starts; the records sink retries (docs/records.md).
  top.text("db", c.db_url);
  if (!c.db_url.empty() && c.db_url.rfind("postgresql://", 0) != 0 &&
      c.db_url.rfind("postgres://", 0) != 0 && c.db_url.rfind("sqlite://", 0) != 0 &&
      c.db_url.front() != '/') {
    top.fail("db",
             "must be postgresql://..., sqlite:///PATH or an absolute path of an SQLite file");
  }
  top.choice("log_level", c.log_level, {"trace", "debug", "info", "warn", "error"});
}

void read_stand(Section& top, DaemonConfig& c) {
  auto s = top.sub("stand");
  if (!s) return;
  c.stand_backend_named = s->find("backend") != nullptr;
  s->choice("backend", c.stand_backend, {"sim", "modbus"});
  s->text("id", c.stand_id);
  s->text("url", c.modbus_url);
  s->text("register_map", c.modbus_map_file);
  if (c.stand_backend == "modbus" && c.modbus_url.empty())
    s->fail("url", "is required for the modbus backend");
  read_range(s->sub("outer").get(), c.outer);
  read_range(s->sub("inner").get(), c.inner);
  if (auto ip = s->sub("in_position")) {
    ip->number("window_deg", c.in_position.window_deg, 1e-6, 10);
    ip->number("dwell_s", c.in_position.dwell_s, 0, 60);
    ip->number("timeout_s", c.in_position.timeout_s, 1, 3600);
    ip->reject_unknown();
  }
  s->number("home_timeout_s", c.home_timeout_s, 1, 3600);
  s->reject_unknown();
}

// unit.static_recording_input: the reading options of `standcal noise` and --unit-static-*, one
// key each, which the reader's messages then name. No g: run.g_local_mps2 puts it in ug.
void read_static_recording_input(Section& s, InputOptions& in) {
  std::string format = "auto", units = "auto", columns;
  s.choice("format", format, {"auto", "standcal", "imu_tk", "delimited", "means"});
  s.choice("units", units, {"auto", "counts", "g", "mps2"});
  in.format = parse_input_format(format);
  in.units = parse_input_units(units);
  s.text("columns", columns);
  if (!columns.empty()) in.columns = split_at_commas(columns);
  double rate_hz = 0;
  s.number("rate_hz", rate_hz, kMinSampleRate_hz, kMaxSampleRate_hz);
  if (rate_hz > 0) in.rate_hz = rate_hz;
  s.integer("skip_lines", in.skip_lines, 0, 1000000);
  s.reject_unknown();
}

void read_unit(Section& top, DaemonConfig& c) {
  auto s = top.sub("unit");
  if (!s) return;
  c.unit_backend_named = s->find("backend") != nullptr;
  s->choice("backend", c.unit_backend, {"sim", "socketcan"});
  s->text("interface", c.can_interface);
  s->text("layout", c.can_layout_file);
  s->number("sample_rate_hz", c.sample_rate_hz, 1, 100000);
  GivenWander& w = c.unit_wander;
  s->number("bias_instability_ug", w.size_ug, 0, kMaxUnitWanderUg);
  s->number("bias_instability_tau_s", w.tau_s, kMinUnitWanderTauS, kMaxUnitWanderTauS);
  double tau_max_s = 0;
  s->number("bias_instability_tau_max_s", tau_max_s, kMinUnitWanderTauS, kMaxUnitWanderTauS);
  const bool tau_given = s->find("bias_instability_tau_s") != nullptr;
  if (tau_max_s > 0 && !tau_given)
    s->fail("bias_instability_tau_max_s",
            "a range needs its lower end too: bias_instability_tau_s");
  if (tau_max_s > 0 && tau_max_s < w.tau_s)
    s->fail("bias_instability_tau_max_s",
            Section::fmt(tau_max_s) + " s is below bias_instability_tau_s (" +
                Section::fmt(w.tau_s) + " s): the range is MIN to MAX");
  if (tau_given) w.known_tau = KnownTau{w.tau_s, tau_max_s > 0 ? tau_max_s : w.tau_s};
  s->text("static_recording", c.unit_static_recording_file);
  // The reader's messages name these keys, given or not.
  c.unit_static_recording_input.option_prefix = "unit.static_recording_input.";
  if (auto input = s->sub("static_recording_input")) {
    if (c.unit_static_recording_file.empty())
      s->fail("static_recording_input", "says how unit.static_recording is read: give it too");
    read_static_recording_input(*input, c.unit_static_recording_input);
  }
  s->reject_unknown();
}

// unit.static_recording, read and fitted once at start (run.g_local_mps2 puts a file in m/s^2
// in ug): the wander its curves pin is the unit's, else the curves that show none or the floor
// they put under a wander they do not pin, which each run's header carries, as `standcal fit
// --unit-static-recording` takes them (take_static_recording_for_runs). A file that cannot be
// read, or has no static stretch, stops the start.
void take_unit_static_recording(DaemonConfig& c) {
  const std::string where = c.source + ": unit.static_recording: ";
  if (c.unit_wander.given())
    throw ConfigError(where +
                      "give the unit's wander either as a static recording or as "
                      "unit.bias_instability_*, not both");
  try {
    FitNoiseOptions nothing_given;
    RawInput file = read_input(c.unit_static_recording_file, c.unit_static_recording_input);
    drop_assumed_gravity_warning(file);  // run.g_local_mps2 puts it in ug
    const UnitStaticAllan s = stand_unit_static_allan(file, c.g_local_mps2);
    c.unit_static_recording = take_static_recording_for_runs(nothing_given, s);
    c.unit_static_curves_ug = nothing_given.wander_curves_ug;
    if (c.unit_static_recording->gave == "floor")
      c.unit_static_tau_floor_s = c.unit_static_recording->tau_floor_s;
  } catch (const std::exception& e) {
    throw ConfigError(where + e.what());
  }
  if (c.unit_static_recording->gave != "wander") return;
  // Each run's header carries it, and its readers refuse what unit.bias_instability_* refuses.
  const GivenWander& w = c.unit_static_recording->wander;
  if (w.size_ug > kMaxUnitWanderUg || w.known_tau->min_s < kMinUnitWanderTauS ||
      w.known_tau->max_s > kMaxUnitWanderTauS)
    throw ConfigError(where + "its Allan curves pin a wander of " + number_text(w.size_ug) +
                      " ug at " + w.known_tau->seconds() +
                      ", outside what unit.bias_instability_* allows (up to " +
                      number_text(kMaxUnitWanderUg) + " ug, " + number_text(kMinUnitWanderTauS) +
                      "-" + number_text(kMaxUnitWanderTauS) + " s)");
  c.unit_wander = w;
}

void read_sim(Section& top, DaemonConfig& c) {
  auto s = top.sub("sim");
  if (!s) return;
  s->number("time_scale", c.sim.time_scale, 0.01, 100000);
  double seed = static_cast<double>(c.sim.seed);
  s->number("seed", seed, 0, 9e15);
  c.sim.seed = static_cast<std::uint64_t>(seed);
  s->number("move_rate_deg_s", c.sim.move_rate_deg_s, 0.1, 1000);
  s->text("truth", c.sim.truth_file);
  s->reject_unknown();
}

void read_run(Section& top, DaemonConfig& c) {
  auto s = top.sub("run");
  if (!s) return;
  s->number("settle_s", c.settle_s, 0, 3600);
  s->number("dwell_s", c.dwell_s, 0.1, 36000);
  s->number("g_local_mps2", c.g_local_mps2, 9.7, 9.9);
  s->text("g_source", c.g_source);
  s->text("budget", c.budget_file);
  if (auto st = s->sub("stability")) {
    st->number("sigma_limit_ug", c.stability.sigma_limit_ug, 0.001, 1e7);
    st->number("trend_limit_ug", c.stability.trend_limit_ug, 0.001, 1e7);
    st->number("trend_limit_sigmas", c.stability.trend_limit_sigmas, 0, 1000);
    st->number("min_sample_fraction", c.stability.min_sample_fraction, 0, 1);
    st->integer("remeasure_max", c.stability.remeasure_max, 0, 100);
    st->reject_unknown();
  }
  if (auto th = s->sub("thermal_wait")) {
    th->flag("enabled", c.thermal.enabled);
    th->number("rate_limit_c_per_min", c.thermal.rate_limit_c_per_min, 1e-6, 100);
    th->number("window_s", c.thermal.window_s, 1, 36000);
    th->number("timeout_s", c.thermal.timeout_s, 1, 360000);
    th->reject_unknown();
  }
  s->reject_unknown();
}

}  // namespace

double most_seconds_of(double samples, double rate_hz) {
  const double s = samples / rate_hz;
  const double step = std::pow(10.0, std::floor(std::log10(s)) - 5);  // the sixth digit's
  // (A quotient a rounding below a whole number of steps keeps it: 2000 s stays 2000.)
  double most = std::floor(s / step + 1e-9) * step;
  if (most * rate_hz > samples) most -= step;
  return most;
}

DaemonConfig parse_config(const json& doc, const std::string& source) {
  DaemonConfig c;
  c.source = source;
  c.document = doc;
  Section top(doc, "", c.source);
  read_server(top, c);
  read_stand(top, c);
  read_unit(top, c);
  read_sim(top, c);
  read_run(top, c);
  if (auto p = top.sub("programs")) {
    p->text("library_dir", c.program_library_dir);
    p->reject_unknown();
  }
  top.reject_unknown();
  if (c.dwell_s * c.sample_rate_hz > kMaxDwellSamples) {
    const auto whole = [](double v) { return std::to_string(std::llround(v)); };
    throw ConfigError(c.source + ": run.dwell_s: " + number_text(c.dwell_s) +
                      " s at unit.sample_rate_hz " + number_text(c.sample_rate_hz) +
                      " Hz would be " + whole(c.dwell_s * c.sample_rate_hz) +
                      " samples a dwell, more than the " + whole(kMaxDwellSamples) +
                      " a dwell holds at once to be judged: at most " +
                      number_text(most_seconds_of(kMaxDwellSamples, c.sample_rate_hz)) + " s");
  }
  if (!c.budget_file.empty()) {
    try {
      c.budget = load_budget_config(c.budget_file);
    } catch (const BudgetConfigError& e) {
      throw ConfigError(c.source + ": run.budget: " + e.what());
    }
  }
  if (!c.unit_static_recording_file.empty()) take_unit_static_recording(c);
  return c;
}

DaemonConfig load_config(const std::string& path) {
  // Reading a directory through a stream throws "basic_filebuf::underflow", naming nothing.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw ConfigError(path + ": is a directory, not a config file (give the JSON file, e.g. " +
                      path + "/standcald.json)");
  }
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the config file: " + std::strerror(errno));
  json doc = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) throw ConfigError(path + ": not valid JSON");
  return parse_config(doc, path);
}

void require_named_backends(const DaemonConfig& c) {
  const auto missing = [&c](const char* key, const char* real) {
    throw ConfigError(
        c.source + ": " + key +
        ": not given, and standcald does not guess which hardware to drive: set it to " + real +
        ", or to \"sim\" for the simulated backend (or start standcald with --sim)");
  };
  if (!c.stand_backend_named) missing("stand.backend", "\"modbus\" (with stand.url)");
  if (!c.unit_backend_named) missing("unit.backend", "\"socketcan\" (with unit.interface)");
}

DaemonConfig sim_config(const std::string& socket_path, const std::string& state_dir,
                        double time_scale) {
  DaemonConfig c;
  c.source = "--sim";
  c.stand_backend_named = c.unit_backend_named = true;
  c.socket_path = socket_path;
  c.state_dir = state_dir;
  c.sim.time_scale = time_scale;
  c.document = json{{"sim", {{"time_scale", time_scale}}},
                    {"socket", {{"path", socket_path}}},
                    {"state_dir", state_dir}};
  return c;
}

bool is_loopback_address(const std::string& address) {
  in_addr v4{};
  if (::inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (::inet_pton(AF_INET6, address.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6) != 0;
  return false;
}

std::string load_tcp_token(const DaemonConfig& config) {
  const std::string& path = config.tcp_token_file;
  const std::string where = config.source + ": tcp.token_file: " + path;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw ConfigError(where + ": cannot read it: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw ConfigError(where + ": is not a regular file");
  // Like ssh with its keys: a secret every local user can read protects nothing.
  if ((st.st_mode & S_IROTH) != 0)
    throw ConfigError(where + ": is readable by every user; chmod 0640 (or 0600) it");
  std::ifstream in(path);
  std::string token;
  if (!in || !std::getline(in, token)) throw ConfigError(where + ": cannot read it or it is empty");
  while (!token.empty() && (token.back() == '\r' || token.back() == ' ' || token.back() == '\t'))
    token.pop_back();
  if (token.size() < 16) {
    throw ConfigError(
        where + ": the token must be at least 16 characters (e.g. `openssl rand -hex 16`); got " +
        std::to_string(token.size()));
  }
  return token;
}

std::string config_hash(const DaemonConfig& config) {
  // FNV-1a over the canonical dump: stable across runs and machines, which is all
  // traceability needs (it identifies, it does not protect).
  const std::string text = config.document.dump();
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : text) {
    h ^= ch;
    h *= 1099511628211ULL;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace standcal::daemon
