// `standcal import`, `standcal history`, `standcal records`: the lab's records database
// (docs/records.md). `records` and not `runs --since`: `standcal runs` already lists the
// daemon's own runs over its socket; `records` filters the database of every bench.
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "calib/atomic_file.hpp"
#include "calib/averaging.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "calib/recording.hpp"
#include "calib/report.hpp"
#include "calib/utc_time.hpp"
#include "protocol/jsonrpc/paths.hpp"
#include "records/db/records_db.hpp"
#include "records/db/unit_history.hpp"
#include "report/history/history.hpp"
#include "standcal/version.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/input_options.hpp"

namespace standcal::cli {

namespace {

using nlohmann::json;
using records::CalibrationRecord;

// Where the records are when --db is not given: $STANDCAL_DB, else the daemon's default.
std::string default_db() {
  const char* env = std::getenv("STANDCAL_DB");
  return (env != nullptr && *env != '\0') ? env : records::default_db_url(paths::kStateDir);
}

void add_db_option(CLI::App* cmd, std::string& db) {
  cmd->add_option("--db", db,
                  "records database: PATH, sqlite:///PATH or postgresql://… "
                  "(default $STANDCAL_DB, else " +
                      records::default_db_url(paths::kStateDir) + ")");
}

// ---- import ------------------------------------------------------------------------

struct ImportOptions {
  std::vector<std::string> recordings;
  std::string db;
  std::string unit_type;
  std::string stand_id;
  std::string operator_name;
  std::string started_utc;
  std::string method = "joint";
  NoiseCliOptions noise;             // as `standcal fit` weights: the unit's known wander, or white
  UnitStaticCliOptions unit_static;  // as `standcal fit`'s: a long static recording of the unit
};

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read the recording");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// FNV-1a: a stable fingerprint, so importing the same file twice gives the same run id.
std::string fingerprint(const std::string& text) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return std::string(buf, 10);
}

std::string file_time_utc(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "";
  return utc_iso(st.st_mtime);
}

FitResult fit_by_method(const std::string& method, const std::vector<PositionAverage>& averages,
                        const FitNoiseOptions& noise) {
  if (method == "joint") return fit_invariant_joint(averages, noise);
  if (method == "paper-sequential") return fit_paper_sequential(averages);
  if (method == "full") {
    FullFitOptions full;
    full.noise = noise;
    return fit_full_vector(averages, full);
  }
  throw std::runtime_error("unknown fit method '" + method + "' (joint, paper-sequential, full)");
}

// The start of the run: --started, else the recording's header, else the file's time.
std::string start_of(const ImportOptions& o, const Recording& rec, const std::string& path,
                     std::vector<std::string>& warnings) {
  if (!o.started_utc.empty()) return records::canonical_utc(o.started_utc);
  const std::string header = rec.header_value("started_utc");
  if (!header.empty()) return records::canonical_utc(header);
  warnings.push_back(path +
                     ": the recording states no started_utc: the file's modification "
                     "time is used");
  return file_time_utc(path);
}

// The unit's static recording, read once for every recording imported and fitted once for
// every g it is put in ug with (once for a file in g).
struct UnitStaticForImport {
  std::optional<RawInput> file;
  std::map<double, UnitStaticAllan> fitted;  // by g; 0 for a file in g

  const UnitStaticAllan* at_g(double g_mps2) {
    if (!file) return nullptr;
    const double key = file->units == InputUnits::g ? 0 : g_mps2;
    auto it = fitted.find(key);
    if (it == fitted.end()) it = fitted.emplace(key, stand_unit_static_allan(*file, g_mps2)).first;
    return &it->second;
  }
};

CalibrationRecord import_record(const ImportOptions& o, const std::string& path,
                                UnitStaticForImport& unit_static) {
  const std::string text = file_text(path);
  const Recording rec = parse_recording(text, path);
  if (rec.unit_serial.empty())
    throw std::runtime_error(path + ": the recording names no unit_serial");
  std::vector<std::string> warnings = rec.warnings;
  AveragedRecording averaged = average_recording(rec);
  if (!averaged.allan_warning.empty()) warnings.push_back(averaged.allan_warning);
  // Nothing of the unit's wander given: its header's, else the one the unit's static recording
  // pins, else the one its own long dwell pins (as `standcal fit`).
  FitNoiseOptions noise = fit_noise_options(o.noise);
  std::optional<UnitStaticRecordingUse> static_use = take_unit_wander_with_static_recording(
      noise, rec, averaged.allan, unit_static.at_g(rec.g_local_mps2));
  FitResult fit = fit_by_method(o.method, averaged.averages, noise);
  if (static_use) settle_unit_static_use(*static_use, fit.noise);
  fit.noise.allan = std::move(averaged.allan);
  CalibrationRecord r;
  const std::string header_run = rec.header_value("run_id");
  // A daemon recording keeps its run id (re-importing it is a no-op); others get one
  // from their content.
  r.run_id =
      header_run.empty() ? "import-" + rec.unit_serial + "-" + fingerprint(text) : header_run;
  r.unit_serial = rec.unit_serial;
  r.unit_type = o.unit_type;
  r.stand_id = !o.stand_id.empty() ? o.stand_id : rec.header_value("stand_id");
  r.g_local_mps2 = rec.g_local_mps2;
  r.g_source = rec.g_from_header ? "recording header (g_local_mps2)" : "ASSUMED standard gravity";
  r.software_version = kVersion;
  r.config_hash = rec.header_value("config_hash");
  r.operator_name = !o.operator_name.empty() ? o.operator_name : rec.header_value("operator");
  r.started_utc = start_of(o, rec, path, warnings);
  r.program_name = rec.program;
  r.recording_path = std::filesystem::absolute(path).string();
  r.method = fit.estimator;
  r.result = fit_to_json(fit);
  r.result["recording_path"] = r.recording_path;
  r.result["recording_warnings"] = warnings;
  r.result["import"] = json{{"source", path}, {"fingerprint", fingerprint(text)}};
  if (static_use) r.result["unit_static_recording"] = unit_static_recording_json(*static_use);
  put_unit_wander_source(r.result, rec);  // as the run's run.result gives it
  r.origin = "import";
  return r;
}

void run_import(const ImportOptions& o) {
  check_unit_static_recording(o.unit_static.path, o.method, o.noise);
  UnitStaticForImport unit_static;
  if (o.unit_static.given()) {
    unit_static.file = read_unit_static_recording(o.unit_static);
    print_warnings(unit_static.file->warnings);
  }
  auto db = records::open_and_migrate(o.db.empty() ? default_db() : o.db);
  int stored = 0;
  for (const std::string& path : o.recordings) {
    const CalibrationRecord r = import_record(o, path, unit_static);
    // Each begins with the file's name, as the reader's do.
    for (const json& w : r.result["recording_warnings"])
      std::fprintf(stderr, "warning: %s\n", w.get<std::string>().c_str());
    const bool inserted = db->insert(r);
    stored += inserted ? 1 : 0;
    std::printf("%s: %s %s (%s, %s, %s)\n", path.c_str(), r.run_id.c_str(),
                inserted ? "imported" : "already in the database, unchanged", r.unit_serial.c_str(),
                r.started_utc.c_str(), r.method.c_str());
  }
  std::printf("%d of %zu recordings imported into %s\n", stored, o.recordings.size(),
              db->location().c_str());
}

// ---- history -----------------------------------------------------------------------

std::string value_text(const std::optional<double>& v, const std::optional<double>& s) {
  if (!v) return "(not observable)";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f ± %.3f", *v, s.value_or(0.0));
  return buf;
}

json history_to_json(const records::UnitHistory& h) {
  json params = json::array();
  for (const records::ParameterHistory& p : h.parameters) {
    json points = json::array(), changes = json::array();
    for (const auto& pt : p.points)
      points.push_back({{"run_id", pt.run_id},
                        {"started_utc", pt.started_utc},
                        {"value", pt.value ? json(*pt.value) : json()},
                        {"sigma", pt.sigma ? json(*pt.sigma) : json()}});
    for (const auto& c : p.changes)
      changes.push_back({{"from_run_id", c.from_run_id},
                         {"to_run_id", c.to_run_id},
                         {"delta", c.delta},
                         {"combined_sigma", c.combined_sigma},
                         {"ageing", c.ageing}});
    params.push_back(
        {{"name", p.name}, {"unit", p.unit}, {"points", points}, {"changes", changes}});
  }
  json cals = json::array();
  for (const CalibrationRecord& r : h.calibrations) {
    json j = records::to_json(r);
    j.erase("result");  // the parameters are above; `standcal records --json` has it whole
    cals.push_back(j);
  }
  return {{"unit_serial", h.unit_serial},
          {"k", h.k},
          {"ageing_flags", h.ageing_flags},
          {"ageing_rule", "|delta| > k * sqrt(sigma_before^2 + sigma_after^2)"},
          {"calibrations", cals},
          {"parameters", params}};
}

void print_history(const records::UnitHistory& h) {
  std::printf("unit %s: %zu calibration%s\n", h.unit_serial.c_str(), h.calibrations.size(),
              h.calibrations.size() == 1 ? "" : "s");
  for (const CalibrationRecord& r : h.calibrations) {
    std::printf("  %s  %-34s stand %-12s %-16s verdict %s\n", r.started_utc.c_str(),
                r.run_id.c_str(), r.stand_id.empty() ? "?" : r.stand_id.c_str(), r.method.c_str(),
                r.verdict.empty() ? "not assessed" : r.verdict.c_str());
  }
  std::printf(
      "ageing: a change between consecutive calibrations beyond k·sqrt(σ1² + σ2²), k = %g\n", h.k);
  for (const records::ParameterHistory& p : h.parameters) {
    std::printf("%s [%s]\n", p.name.c_str(), p.unit.c_str());
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      const auto& pt = p.points[i];
      std::string change;
      for (const auto& c : p.changes) {
        if (c.to_run_id != pt.run_id) continue;
        char buf[96];
        std::snprintf(buf, sizeof buf, "  Δ %+.3f (%.1f σ)%s", c.delta,
                      c.combined_sigma > 0 ? std::abs(c.delta) / c.combined_sigma : 0.0,
                      c.ageing ? "  AGEING" : "");
        change = buf;
      }
      std::printf("  %s  %-24s%s\n", pt.started_utc.c_str(), value_text(pt.value, pt.sigma).c_str(),
                  change.c_str());
    }
  }
  std::printf("%d change%s flagged as ageing\n", h.ageing_flags, h.ageing_flags == 1 ? "" : "s");
}

// ---- records -----------------------------------------------------------------------

void print_records(const std::vector<CalibrationRecord>& list) {
  if (list.empty()) {
    std::printf("no calibrations match\n");
    return;
  }
  std::printf("%-20s  %-34s %-12s %-10s %-12s %-16s %s\n", "started (UTC)", "run id", "unit",
              "type", "stand", "method", "verdict");
  for (const CalibrationRecord& r : list) {
    std::printf("%-20s  %-34s %-12s %-10s %-12s %-16s %s\n", r.started_utc.c_str(),
                r.run_id.c_str(), r.unit_serial.c_str(),
                r.unit_type.empty() ? "-" : r.unit_type.c_str(),
                r.stand_id.empty() ? "-" : r.stand_id.c_str(), r.method.c_str(),
                r.verdict.empty() ? "not assessed" : r.verdict.c_str());
  }
  std::printf("%zu calibration%s\n", list.size(), list.size() == 1 ? "" : "s");
}

void add_import_command(CLI::App& app) {
  auto o = std::make_shared<ImportOptions>();
  auto* cmd = app.add_subcommand("import",
                                 "re-fit recordings (from before the database, or another bench) "
                                 "and store them in the records database");
  // A file name the database cannot keep (it stores the path) is refused before the first
  // file is fitted, not after the earlier files are stored.
  cmd->add_option("recordings", o->recordings, "recordings (standcal-recording/1 CSV)")
      ->required()
      ->check(cli_checks::kUtf8Text & cli_checks::kUtf8FullPath & CLI::ExistingFile);
  add_db_option(cmd, o->db);
  cmd->add_option("--unit-type", o->unit_type, "the units' type (limits are per type)")
      ->check(cli_checks::kUtf8Text);
  cmd->add_option("--stand-id", o->stand_id,
                  "the stand that recorded them (default: the recording's stand_id)")
      ->check(cli_checks::kUtf8Text);
  cmd->add_option("--operator", o->operator_name,
                  "who ran them (default: the recording's operator)")
      ->check(cli_checks::kUtf8Text);
  cmd->add_option("--started", o->started_utc,
                  "when they ran, UTC (default: the recording's started_utc, else the file time)");
  cmd->add_option("--method", o->method, "joint | paper-sequential | full")->capture_default_str();
  add_noise_options(cmd, o->noise);
  add_unit_static_recording_option(
      cmd, o->unit_static,
      "the wander its Allan curves pin is taken as the unit's where a recording's "
      "header gives none, or where they show none, they bound the "
      "wander the fit's sigmas allow for, or where they see one they do "
      "not pin, they put a floor under its correlation time");
  cmd->callback([o] { run_import(*o); });
}

// The page's plain structs from the database's history (same parameters, same order).
report::UnitHistory history_for_plot(const records::UnitHistory& h) {
  report::UnitHistory page;
  page.unit_serial = h.unit_serial;
  page.coverage_factor = h.k;
  for (const records::CalibrationRecord& c : h.calibrations) {
    report::HistoryCalibration cal;
    cal.run_id = c.run_id;
    cal.date_utc = c.started_utc;
    cal.verdict = c.verdict;
    if (page.unit_type.empty()) page.unit_type = c.unit_type;
    for (std::size_t i = 0; i < h.parameters.size() && i < cal.parameters.size(); ++i) {
      for (const records::ParameterPoint& p : h.parameters[i].points) {
        if (p.run_id == c.run_id) cal.parameters[i] = {p.value, p.sigma};
      }
    }
    page.calibrations.push_back(std::move(cal));
  }
  // The database history has judged its calibrations already: the page says the same.
  page.changes.emplace();
  for (std::size_t i = 0; i < h.parameters.size() && i < page.changes->size(); ++i)
    (*page.changes)[i] = h.parameters[i].changes;
  return page;
}

void write_history_page(const records::UnitHistory& h, const std::string& path) {
  const std::string html = report::render_history_html(history_for_plot(h));
  write_file_atomically(path, html, "the history page");
}

void add_history_command(CLI::App& app) {
  auto serial = std::make_shared<std::string>();
  auto db = std::make_shared<std::string>();
  auto as_json = std::make_shared<bool>(false);
  auto k = std::make_shared<double>(2.0);
  auto plot = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand(
      "history", "every calibration of one unit, each parameter over time, ageing flagged");
  cmd->add_option("serial", *serial, "unit serial")->required()->check(cli_checks::kUtf8Text);
  add_db_option(cmd, *db);
  cmd->add_option("--k", *k, "flag a change beyond k combined σ")
      ->capture_default_str()
      ->check(cli_checks::kPositive);
  cmd->add_flag("--json", *as_json, "machine-readable output");
  cmd->add_option("--plot", *plot,
                  "also write an HTML page plotting each parameter over time (±k·σ)");
  cmd->callback([=] {
    auto d =
        records::open_and_migrate(db->empty() ? default_db() : *db, records::OpenMode::existing);
    const records::UnitHistory h = records::unit_history(*serial, d->history(*serial), *k);
    if (h.calibrations.empty())
      throw std::runtime_error("no calibrations of unit " + *serial + " in " + d->location());
    if (!plot->empty()) write_history_page(h, *plot);
    if (*as_json) {
      std::cout << json_text(history_to_json(h)) << "\n";
    } else {
      print_history(h);
    }
  });
}

void add_records_command(CLI::App& app) {
  auto f = std::make_shared<records::RecordFilter>();
  auto db = std::make_shared<std::string>();
  auto as_json = std::make_shared<bool>(false);
  auto* cmd =
      app.add_subcommand("records", "calibrations in the records database, oldest first, filtered");
  add_db_option(cmd, *db);
  cmd->add_option("--since", f->since_utc,
                  "from this date or UTC time (2026-11-01, 2026-11-01T08:00:00Z)");
  cmd->add_option("--until", f->until_utc, "up to this date (whole day) or UTC time");
  // The database holds UTF-8 text only (PostgreSQL refused such a filter with its own error).
  cmd->add_option("--unit-serial,--serial", f->unit_serial, "only this unit")
      ->check(cli_checks::kUtf8Text);
  cmd->add_option("--unit-type", f->unit_type, "only this unit type")->check(cli_checks::kUtf8Text);
  cmd->add_option("--verdict", f->verdict, "pass, indeterminate, fail or none (not assessed)")
      ->check(CLI::IsMember({"pass", "indeterminate", "fail", "none"}));
  cmd->add_option("--limit", f->limit, "at most this many")->check(cli_checks::kNonNegative);
  cmd->add_flag("--json", *as_json, "machine-readable output (whole records)");
  cmd->callback([=] {
    auto d =
        records::open_and_migrate(db->empty() ? default_db() : *db, records::OpenMode::existing);
    const auto list = d->list(*f);
    if (*as_json) {
      json out = json::array();
      for (const CalibrationRecord& r : list) out.push_back(records::to_json(r));
      std::cout << json_text(out) << "\n";
    } else {
      print_records(list);
    }
  });
}

void add_records_commands(CLI::App& app) {
  add_import_command(app);
  add_history_command(app);
  add_records_command(app);
}

}  // namespace

static const bool records_commands_registered = register_command_group(add_records_commands);

}  // namespace standcal::cli
