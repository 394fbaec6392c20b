// `standcal design evaluate|optimize|compare` (experiment design), issue 3.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "calib/atomic_file.hpp"
#include "calib/design.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "tools/cli_checks.hpp"
#include "tools/standcal/commands.hpp"
#include "tools/standcal/input_options.hpp"

namespace standcal::cli {
namespace {

using nlohmann::json;

struct DesignFlags {
  DesignSettings settings;
  std::string model = "auto";
  std::string mounting = "common";
  std::string limits;
  bool json = false;
  UnitStaticCliOptions unit_static;  // in place of the noise flags
};

struct EvaluateOptions {
  DesignFlags flags;
  std::string program;
  int repeat = 1;
  std::string program_out;
};

struct OptimizeCliOptions {
  DesignFlags flags;
  int max_repeats = 4;
  int positions = 9;
  std::string structure;
  int restarts = 6;
  unsigned seed = 1;
  std::string target = "bias=2ug,scale=2ppm,gamma=1asec";
  std::string program_out;
};

struct CompareOptions {
  DesignFlags flags;
  std::vector<std::string> programs;
  std::string target = "bias=2ug,scale=2ppm,gamma=1asec";
  int with_optimal = 0;
  int max_repeats = 4;
};

void add_design_flags(CLI::App* cmd, DesignFlags& f) {
  cmd->add_option("--noise-density-ug-rthz", f.settings.noise_density_ug_rthz,
                  "white noise density of the unit, ug/sqrt(Hz) (see `standcal noise`)")
      ->check(cli_checks::kPositive)
      ->capture_default_str();
  add_wander_options(cmd, f.settings.bias_instability_ug, f.settings.bias_instability_tau_s,
                     "shared by dwell means close in time; 0: white noise only");
  cmd->add_option("--bias-instability-tau-max-s", f.settings.bias_instability_tau_max_s,
                  "the correlation time lies between --bias-instability-tau-s and this (the "
                  "range `standcal noise` gives): the predicted sigmas are averaged over it, as "
                  "the fits given that range average theirs")
      ->check(cli_checks::kPositive);
  CLI::Option* from_file = add_unit_static_recording_option(
      cmd, f.unit_static,
      "the white noise fitted beside its wander "
      "and the wander it pins (the largest axis's), "
      "in place of --noise-density-ug-rthz and --bias-instability-*");
  for (const char* given : {"--noise-density-ug-rthz", "--bias-instability-ug",
                            "--bias-instability-tau-s", "--bias-instability-tau-max-s"})
    from_file->excludes(cmd->get_option(given));
  cmd->add_option("--settle-s", f.settings.settle_s, "settle time per position, s")
      ->check(cli_checks::kNonNegative)
      ->capture_default_str();
  cmd->add_option("--move-rate-deg-s", f.settings.move_rate_deg_s, "stand slew rate, deg/s")
      ->check(cli_checks::kPositive)
      ->capture_default_str();
  cmd->add_option("--remount-s", f.settings.remount_s, "operator time per re-mount, s")
      ->check(cli_checks::kNonNegative)
      ->capture_default_str();
  cmd->add_option(
         "--model", f.model,
         "invariant | full | auto (invariant unless it cannot see every parameter, e.g. classic24)")
      ->capture_default_str();
  cmd->add_option(
         "--mounting", f.mounting,
         "full model: common (unit in one rigid fixture) | per-mount (independent re-mount errors)")
      ->capture_default_str();
  cmd->add_option("--limits", f.limits,
                  "stand ranges, e.g. alpha1=-180:180,alpha2=-90:270 (default: continuous)");
  cmd->add_flag("--json", f.json, "machine-readable output");
}

void add_max_repeats(CLI::App* cmd, int& max_repeats) {
  cmd->add_option("--max-repeats", max_repeats,
                  "with --bias-instability-ug: also the programme visited up to N times in a row")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
}

AxisRange parse_axis_range(const std::string& item, const std::string& text) {
  AxisRange r;
  if (text == "continuous") {
    r.continuous = true;
    return r;
  }
  const auto colon = text.find(':');
  // Each bound wholly a number: std::stod took "-90x" as -90.
  const auto whole_number = [](std::string_view s, double& out) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return !s.empty() && ec == std::errc{} && end == s.data() + s.size();
  };
  if (colon == std::string::npos ||
      !whole_number(std::string_view(text).substr(0, colon), r.min_deg) ||
      !whole_number(std::string_view(text).substr(colon + 1), r.max_deg))
    throw std::runtime_error("--limits '" + item +
                             "': expected MIN:MAX in degrees or 'continuous'");
  if (!(r.max_deg > r.min_deg))
    throw std::runtime_error("--limits '" + item + "': MAX must exceed MIN");
  return r;
}

StandLimits parse_limits(const std::string& text) {
  StandLimits limits;
  limits.alpha1.continuous = limits.alpha2.continuous = true;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    if (eq == std::string::npos || (key != "alpha1" && key != "alpha2"))
      throw std::runtime_error("--limits '" + item +
                               "': expected alpha1=MIN:MAX or alpha2=MIN:MAX");
    (key == "alpha1" ? limits.alpha1 : limits.alpha2) = parse_axis_range(item, item.substr(eq + 1));
  }
  return limits;
}

MountingModel parse_mounting(const std::string& text) {
  if (text == "common") return MountingModel::common_fixture;
  if (text == "per-mount") return MountingModel::per_mount;
  throw std::runtime_error("--mounting '" + text + "': expected common or per-mount");
}

std::string wander_words(const DesignSettings& s) {
  if (!s.wander()) return "white noise only";
  const KnownTau tau = s.wander_tau();
  char buf[200];
  std::snprintf(buf, sizeof buf, "bias wander %.3g ug (Gauss-Markov, tau %s%s)",
                s.bias_instability_ug, tau.seconds().c_str(),
                tau.range() ? ": the sigmas averaged over the range" : "");
  return buf;
}

// --unit-static-recording: the white noise and the wander the unit's static recording shows, as
// `standcal noise` measures them (the largest axis's, one size, where the fits weigh each axis
// with its own; the correlation times as the fits take them from the recording), in place of
// the flags'. Curves that see a wander the fits would not take are
// refused: white noise alone, and the white noise fitted beside that wander, would promise too
// much. Said on stderr, and in the JSON's noise_from.
void take_static_recording_noise(const UnitStaticCliOptions& o, DesignSettings& s) {
  const RawInput in = read_unit_static_recording(o);
  print_warnings(in.warnings);
  const UnitStaticAllan a = stand_unit_static_allan(in, in.g_mps2);
  // The white noise fitted beside the wander; the curves' reading at 1 s where none was fitted.
  double density = 0;
  if (a.gauss_markov)
    for (double n : a.gauss_markov->white_density) density = std::max(density, n);
  else
    for (const NoiseFigures& f : a.allan.figures)
      if (f.white_density) density = std::max(density, *f.white_density);
  if (!(density > 0))
    throw std::runtime_error(
        o.path + ": the unit's static recording gives no white noise density (" + a.use.why + ")");
  s.noise_density_ug_rthz = density;
  s.bias_instability_ug = 0;
  s.bias_instability_tau_max_s = 0;
  char white[96];
  std::snprintf(white, sizeof white, "white noise %.3g ug/sqrt(Hz) and ", density);
  FitNoiseOptions nothing_given;
  const UnitStaticRecordingUse use = take_static_recording_pinned_wander(nothing_given, a);
  std::string wander = "no wander: " + a.use.why;
  if (use.gave == "wander") {
    s.bias_instability_ug = use.wander.size_ug;
    s.bias_instability_tau_s = use.wander.known_tau->min_s;
    if (use.wander.known_tau->range()) s.bias_instability_tau_max_s = use.wander.known_tau->max_s;
    wander = wander_words(s);
  } else if (a.gauss_markov && a.gauss_markov->wander_seen) {
    throw std::runtime_error(o.path + ": " + use.why +
                             ": record the unit longer, or give --noise-density-ug-rthz and "
                             "--bias-instability-* as they are known");
  }
  s.noise_from = unit_static_recording_name(a.use) + ": " + white + wander;
  s.noise_from_warnings = a.use.warnings;
  std::fprintf(stderr, "noise from %s\n", s.noise_from.c_str());
}

// The settings the flags describe, the mounting parsed and the correlation time's range
// checked as the fits check it (the design's --bias-instability-tau-s has a default, so a
// range needs only its upper end).
DesignSettings settings_of(const DesignFlags& f) {
  DesignSettings s = f.settings;
  s.mounting = parse_mounting(f.mounting);
  if (f.unit_static.given()) take_static_recording_noise(f.unit_static, s);
  WanderCliOptions as_fits_take_it;
  as_fits_take_it.bias_instability_tau_s = s.bias_instability_tau_s;
  as_fits_take_it.bias_instability_tau_max_s = s.bias_instability_tau_max_s;
  as_fits_take_it.tau_given = true;
  as_fits_take_it.known_tau();  // throws CLI::ValidationError for a range upside down
  if (s.bias_instability_tau_max_s > 0 && !s.wander())
    throw CLI::ValidationError("--bias-instability-tau-max-s",
                               "a correlation time needs the wander it belongs to: "
                               "--bias-instability-ug");
  return s;
}

// The model a programme is evaluated with, and the note saying why when chosen for it.
DesignModel choose_model(const Program& program, const std::string& requested, std::string& note) {
  if (requested == "invariant") return DesignModel::invariant;
  if (requested == "full") return DesignModel::full;
  if (requested != "auto")
    throw std::runtime_error("--model '" + requested + "': expected invariant, full or auto");
  const DesignBasis inv = design_basis(poses_of(program), DesignModel::invariant);
  for (int i = 0; i < kUnitParameterCount; ++i) {
    if (inv.unit_column[i] < 0) {
      note = program.name +
             " is evaluated with the full model: the invariant model cannot see its " +
             std::string(kUnitParameterNames[i]) + " (" + inv.unobservable_reason[i] + ")";
      return DesignModel::full;
    }
  }
  return DesignModel::invariant;
}

json time_json(const BenchTime& t) {
  json j = {{"move_s", t.move_s},     {"settle_s", t.settle_s},   {"dwell_s", t.dwell_s},
            {"remounts", t.remounts}, {"remount_s", t.remount_s}, {"total_s", t.total_s()}};
  if (t.warmup_s > 0) j["warmup_s"] = t.warmup_s;
  return j;
}

std::string format_time(const BenchTime& t) {
  char buf[256];
  char warm_up[48] = "";
  if (t.warmup_s > 0) std::snprintf(warm_up, sizeof warm_up, " + warm-up %.0f s", t.warmup_s);
  std::snprintf(buf, sizeof buf,
                "%.0f s (moves %.0f s + settle %.0f s%s + dwell %.0f s + %d re-mount(s) %.0f s)",
                t.total_s(), t.move_s, t.settle_s, warm_up, t.dwell_s, t.remounts, t.remount_s);
  return buf;
}

// The wander as the JSON states it: its correlation time's upper end null when one value.
void add_wander_json(json& j, const DesignSettings& s) {
  j["bias_instability_ug"] = s.bias_instability_ug;
  j["bias_instability_tau_s"] = s.bias_instability_tau_s;
  j["bias_instability_tau_max_s"] =
      s.wander_tau().range() ? json(s.bias_instability_tau_max_s) : json(nullptr);
  if (!s.noise_from.empty()) {
    j["noise_from"] = s.noise_from;
    j["noise_from_warnings"] = s.noise_from_warnings;
  }
}

void print_json(const json& j) { std::cout << json_text(j) << "\n"; }

// ---- evaluate ------------------------------------------------------------------------

// The programme with each position's dwell written out, as `standcal run start` and the
// daemon's programme library read it.
void write_timed_program(const Program& program, const std::vector<double>& dwell_s,
                         const std::string& path) {
  Program timed = program;
  for (std::size_t k = 0; k < timed.positions.size() && k < dwell_s.size(); ++k)
    timed.positions[k].dwell_s = dwell_s[k];
  write_file_atomically(path, json_text(program_to_json(timed)) + "\n", "the programme");
}

void run_evaluate(const EvaluateOptions& o) {
  const DesignSettings settings = settings_of(o.flags);
  const Program program = repeated_program(load_program(o.program), o.repeat);
  std::string model_note;
  const DesignModel model = choose_model(program, o.flags.model, model_note);
  const DesignEvaluation ev = evaluate_design(program, model, settings);
  if (!o.program_out.empty()) write_timed_program(program, ev.dwell_s, o.program_out);

  json params = json::object();
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const std::string name(kUnitParameterNames[i]);
    if (ev.unit_sigma[i]) {
      params[name] = {{"sigma", *ev.unit_sigma[i]}, {"unit", kUnitParameterUnits[i]}};
      if (ev.white_unit_sigma[i]) params[name]["sigma_white_noise_only"] = *ev.white_unit_sigma[i];
    } else
      params[name] = {{"sigma", nullptr},
                      {"unit", kUnitParameterUnits[i]},
                      {"reason", ev.unobservable_reason[i]}};
  }
  std::vector<std::string> notes = ev.notes;
  if (!model_note.empty()) notes.insert(notes.begin(), model_note);
  if (o.flags.json) {
    json info = json::array();
    for (int r = 0; r < ev.information.rows(); ++r) {
      json row = json::array();
      for (int c = 0; c < ev.information.cols(); ++c) row.push_back(ev.information(r, c));
      info.push_back(row);
    }
    json j = {{"program", program.name},
              {"positions", program.positions.size()},
              {"model", design_model_name(model)},
              {"noise_density_ug_rthz", settings.noise_density_ug_rthz},
              {"dwell_s", ev.dwell_s},
              {"parameters", params},
              {"d_criterion", ev.d_criterion},
              {"a_criterion", ev.a_criterion},
              {"information",
               {{"parameters", ev.parameter_names},
                {"units", "internal (g, 1, rad), per g^2"},
                {"matrix", info}}},
              {"notes", notes},
              {"bench_time", time_json(ev.time)}};
    add_wander_json(j, settings);
    print_json(j);
    return;
  }
  std::printf(
      "programme %s: %zu positions, %s model, noise %.3g ug/sqrt(Hz), %s, settle %.3g s, move "
      "%.3g deg/s\n",
      program.name.c_str(), program.positions.size(), design_model_name(model).c_str(),
      settings.noise_density_ug_rthz, wander_words(settings).c_str(), settings.settle_s,
      settings.move_rate_deg_s);
  std::printf("\npredicted 1 sigma for the dwells given (first position %.3g s)%s:\n",
              ev.dwell_s.front(), settings.wander() ? ", and under the white noise alone" : "");
  for (int i = 0; i < kUnitParameterCount; ++i) {
    if (ev.unit_sigma[i] && ev.white_unit_sigma[i])
      std::printf("  %-8s %10.3f %-6s (white noise alone %.3f)\n",
                  std::string(kUnitParameterNames[i]).c_str(), *ev.unit_sigma[i],
                  std::string(kUnitParameterUnits[i]).c_str(), *ev.white_unit_sigma[i]);
    else if (ev.unit_sigma[i])
      std::printf("  %-8s %10.3f %s\n", std::string(kUnitParameterNames[i]).c_str(),
                  *ev.unit_sigma[i], std::string(kUnitParameterUnits[i]).c_str());
    else
      std::printf("  %-8s %10s  %s\n", std::string(kUnitParameterNames[i]).c_str(), "-",
                  ev.unobservable_reason[i].c_str());
  }
  std::printf("\nD-criterion det(M_unit)^(1/9) = %.5g, A-criterion trace(M_unit^-1) = %.5g\n",
              ev.d_criterion, ev.a_criterion);
  std::printf(
      "  (per unit measurement variance, one measurement per position; larger D / smaller A is "
      "better)\n");
  std::printf("bench time: %s\n", format_time(ev.time).c_str());
  std::printf(
      "\ninformation matrix (parameters in g, 1 and rad; for these dwells and noise), "
      "rows/columns:\n ");
  for (const auto& n : ev.parameter_names) std::printf(" %s;", n.c_str());
  std::printf("\n");
  // Entries at rounding level of the largest are exact zeros of the design: print them so.
  const double zero_below = 1e-12 * ev.information.cwiseAbs().maxCoeff();
  for (int r = 0; r < ev.information.rows(); ++r) {
    std::printf(" ");
    for (int c = 0; c < ev.information.cols(); ++c) {
      const double v = ev.information(r, c);
      std::printf(" %10.3e", std::abs(v) < zero_below ? 0.0 : v);
    }
    std::printf("\n");
  }
  if (!notes.empty()) {
    std::printf("\nunobservable and constrained:\n");
    for (const auto& n : notes) std::printf("  - %s\n", n.c_str());
  }
  if (!o.program_out.empty())
    std::printf("\nprogramme with its dwells written to %s\n", o.program_out.c_str());
}

// ---- optimize / compare --------------------------------------------------------------

struct ProgrammeDwell {
  std::string name;
  DesignModel model;
  std::string note;
  DwellPlan equal, allocated;
  BenchTime equal_time, allocated_time;
  // With bias wander: of the programme visited 1 .. max_repeats times, the one that meets
  // the target in the least bench time (none when no pass count does).
  bool revisits_tried = false;
  std::optional<RevisitPlan> best_revisit;
};

ProgrammeDwell dwell_for(const Program& program, const std::string& requested_model,
                         const AccuracyTarget& target, const DesignSettings& settings,
                         int max_repeats = 1) {
  ProgrammeDwell d;
  d.name = program.name;
  d.model = choose_model(program, requested_model, d.note);
  const DesignBasis basis = design_basis(poses_of(program), d.model, settings.mounting);
  d.equal = equal_dwell_for_target(basis, program, target, settings);
  d.allocated = allocated_dwell_for_target(basis, program, target, settings);
  if (d.equal.feasible) d.equal_time = bench_time(program, settings, d.equal.dwell_s);
  if (d.allocated.feasible) d.allocated_time = bench_time(program, settings, d.allocated.dwell_s);
  d.revisits_tried = settings.wander() && max_repeats > 1;
  if (d.revisits_tried)
    d.best_revisit = fastest_revisit(program, d.model, target, settings, max_repeats,
                                     RevisitPlan{1, d.equal, d.equal_time});
  return d;
}

json revisit_json(const std::optional<RevisitPlan>& r) {
  if (!r) return {{"feasible", false}};
  return {{"times", r->times},
          {"dwell_per_visit_s", r->equal.dwell_s.front()},
          {"total_dwell_s", r->equal.total_dwell_s},
          {"limiting_parameter", r->equal.limiting_parameter},
          {"bench_time", time_json(r->time)}};
}

json dwell_json(const ProgrammeDwell& d) {
  json j = {{"program", d.name}, {"model", design_model_name(d.model)}};
  if (!d.note.empty()) j["note"] = d.note;
  if (d.revisits_tried) j["best_revisit"] = revisit_json(d.best_revisit);
  if (!d.equal.feasible) {
    j["feasible"] = false;
    j["reason"] = d.equal.reason;
    return j;
  }
  j["equal"] = {{"dwell_per_position_s", d.equal.dwell_s.front()},
                {"total_dwell_s", d.equal.total_dwell_s},
                {"limiting_parameter", d.equal.limiting_parameter},
                {"bench_time", time_json(d.equal_time)}};
  if (!d.allocated.feasible)
    j["allocated"] = {{"feasible", false}, {"reason", d.allocated.reason}};
  else
    j["allocated"] = {{"dwell_s", d.allocated.dwell_s},
                      {"total_dwell_s", d.allocated.total_dwell_s},
                      {"bench_time", time_json(d.allocated_time)}};
  return j;
}

void print_revisit(const ProgrammeDwell& d) {
  if (!d.best_revisit) {
    std::printf("  %-28s %-9s no pass count tried meets the target\n", "", "");
    return;
  }
  const RevisitPlan& r = *d.best_revisit;
  // Rounded up: a dwell given as printed still meets the target.
  const double per_visit_s = std::ceil(r.equal.dwell_s.front() * 10) / 10;
  std::printf("  %-28s %-9s revisited x%d: %.1f s per visit, %.1f s total dwell, bench %.0f s%s\n",
              "", "", r.times, per_visit_s, r.equal.total_dwell_s, r.time.total_s(),
              r.times == 1 ? " (one pass is best)" : "");
}

void print_dwell_row(const ProgrammeDwell& d) {
  if (!d.equal.feasible) {
    std::printf("  %-28s %-9s cannot reach the target: %s\n", d.name.c_str(),
                design_model_name(d.model).c_str(), d.equal.reason.c_str());
  } else if (!d.allocated.feasible) {
    std::printf("  %-28s %-9s %8.1f %8.1f (%-8s) %8s %8.0f %8s\n", d.name.c_str(),
                design_model_name(d.model).c_str(), d.equal.dwell_s.front(), d.equal.total_dwell_s,
                d.equal.limiting_parameter.c_str(), "-", d.equal_time.total_s(), "-");
  } else {
    std::printf("  %-28s %-9s %8.1f %8.1f (%-8s) %8.1f %8.0f %8.0f\n", d.name.c_str(),
                design_model_name(d.model).c_str(), d.equal.dwell_s.front(), d.equal.total_dwell_s,
                d.equal.limiting_parameter.c_str(), d.allocated.total_dwell_s,
                d.equal_time.total_s(), d.allocated_time.total_s());
  }
  if (d.revisits_tried) print_revisit(d);
}

void print_dwell_header(const AccuracyTarget& t, const DesignSettings& s) {
  std::printf(
      "target 1 sigma: bias %.3g ug, scale %.3g ppm, gamma %.3g arcsec; noise %.3g ug/sqrt(Hz), "
      "%s; settle %.3g s, move %.3g deg/s, re-mount %.3g s\n\n",
      t.bias_ug, t.scale_ppm, t.gamma_arcsec, s.noise_density_ug_rthz, wander_words(s).c_str(),
      s.settle_s, s.move_rate_deg_s, s.remount_s);
  std::printf("  %-28s %-9s %8s %8s %10s %8s %8s %8s\n", "programme", "model", "dwell/pos", "equal",
              "(limiting)", "alloc", "bench=", "bench~");
  std::printf("  %-28s %-9s %8s %8s %10s %8s %8s %8s\n", "", "", "s", "total s", "", "total s",
              "equal s", "alloc s");
}

json positions_json(const Program& program, const std::vector<double>& allocated_dwell_s) {
  json positions = json::array();
  for (std::size_t k = 0; k < program.positions.size(); ++k) {
    const auto& p = program.positions[k];
    positions.push_back(
        {{"alpha1_deg", p.alpha1_deg},
         {"alpha2_deg", p.alpha2_deg},
         {"allocated_dwell_s", k < allocated_dwell_s.size() ? allocated_dwell_s[k] : 0.0}});
  }
  return positions;
}

json bench_s_json(const std::optional<RevisitPlan>& plan) {
  return plan ? json(plan->time.total_s()) : json();
}

// white_d: white noise's optimum's D-criterion, from its own basis as the moved one's is.
json polish_json(const WanderPolish& polish, const Program& white_optimum, double white_d) {
  json j = {{"rounds", polish.rounds},
            {"white_optimum_positions", positions_json(white_optimum, {})},
            {"white_optimum_d_criterion", white_d}};
  j["white_optimum_bench_s"] = bench_s_json(polish.start_plan);
  j["bench_s"] = bench_s_json(polish.plan);
  return j;
}

// What the angles were chosen for, under a wander.
void print_polish(const std::optional<WanderPolish>& polish, double white_d) {
  if (!polish) {
    std::printf(
        "  the angles are D-optimal for white noise (the paper structure fixes their pattern); "
        "the dwells and revisits planned here allow for the wander\n");
  } else if (!polish->start_plan) {
    std::printf(
        "  the angles are D-optimal for white noise: no plan of them meets the target, so "
        "none was there to move them for the wander by\n");
  } else if (polish->rounds == 0) {
    std::printf(
        "  the angles are D-optimal for white noise: moving them for the wander found no "
        "faster plan (%.0f s on the bench)\n",
        polish->start_plan->time.total_s());
  } else {
    std::printf(
        "  the angles are white noise's D-optimum (det^(1/9) %.5f) moved for the wander in %d "
        "round%s: its fastest plan takes %.0f s on the bench, against %.0f s at white noise's "
        "angles\n",
        white_d, polish->rounds, polish->rounds == 1 ? "" : "s", polish->plan->time.total_s(),
        polish->start_plan->time.total_s());
  }
}

// Writes `-o`: under a wander the fastest plan the table prints (its passes, each visit's
// dwell), otherwise the allocated dwells. Returns what was written, in words.
std::string write_optimized_program(const Program& chosen, const ProgrammeDwell& dwell,
                                    const DesignSettings& settings, const std::string& path) {
  if (settings.wander() && dwell.best_revisit) {
    const RevisitPlan& r = *dwell.best_revisit;
    write_timed_program(repeated_program(chosen, r.times), r.equal.dwell_s, path);
    return "programme visited " + std::to_string(r.times) + (r.times == 1 ? " time" : " times") +
           " with the fastest plan's dwells (equal, for the wander) written to " + path;
  }
  write_timed_program(chosen, dwell.allocated.dwell_s, path);
  return "programme with allocated dwells written to " + path;
}

// The model `design optimize` and `compare --with-optimal` optimise for: full when asked,
// else the invariant one (`auto` too).
DesignModel optimized_model(const std::string& requested) {
  return requested == "full" ? DesignModel::full : DesignModel::invariant;
}

// Under a wander, white noise's optimum moved for it (a paper structure fixes the angles'
// pattern, and keeps them); none without a wander.
std::optional<WanderPolish> moved_for_wander(const OptimizeOptions& opt, const Program& white,
                                             const AccuracyTarget& target,
                                             const DesignSettings& settings, int max_repeats) {
  if (!settings.wander() || opt.paper_structure) return std::nullopt;
  return polish_for_wander(white, opt.model, opt.limits, target, settings, max_repeats);
}

OptimizeOptions optimize_options_of(const OptimizeCliOptions& o) {
  OptimizeOptions opt;
  opt.positions = o.positions;
  opt.model = optimized_model(o.flags.model);
  if (o.flags.model != "full" && o.flags.model != "invariant" && o.flags.model != "auto")
    throw std::runtime_error("--model '" + o.flags.model + "': expected invariant or full");
  if (!o.structure.empty() && o.structure != "paper")
    throw std::runtime_error("--structure '" + o.structure +
                             "': the only structure known is 'paper'");
  opt.paper_structure = o.structure == "paper";
  if (!o.flags.limits.empty())
    opt.limits = parse_limits(o.flags.limits);
  else
    opt.limits.alpha1.continuous = opt.limits.alpha2.continuous = true;
  opt.restarts = o.restarts;
  opt.seed = o.seed;
  return opt;
}

// What `design optimize` found: white noise's optimum, under a wander moved for it, and the
// dwell plans of the programme chosen and of paper9.
struct OptimizeOutcome {
  DesignModel model = DesignModel::invariant;
  OptimizedProgram white;
  std::optional<WanderPolish> polish;  // under a wander, unless a structure fixes the angles
  Program chosen;
  // det^(1/9), each from the programme's own basis as paper9's is (the exchange's figure is
  // over the parameters the whole stand observes: the same for the white optimum, not for a
  // moved one).
  double white_d = 0, chosen_d = 0;
  ProgrammeDwell dwell, paper;
  bool polished() const { return polish && polish->rounds > 0; }
  double gain() const { return chosen_d / white.paper9_d_criterion; }
  // det^(1/9) grows with the number of positions; dividing by it compares like with like.
  double per_position_gain() const {
    return gain() * static_cast<double>(paper9().positions.size()) /
           static_cast<double>(chosen.positions.size());
  }
};

OptimizeOutcome optimize(const OptimizeOptions& opt, const AccuracyTarget& target,
                         const DesignSettings& settings, int max_repeats) {
  OptimizeOutcome out;
  out.model = opt.model;
  out.white = optimize_program(opt);
  out.polish = moved_for_wander(opt, out.white.program, target, settings, max_repeats);
  out.chosen = out.polished() ? out.polish->program : out.white.program;
  out.white_d = d_criterion(design_basis(poses_of(out.white.program), opt.model));
  out.chosen_d =
      out.polished() ? d_criterion(design_basis(poses_of(out.chosen), opt.model)) : out.white_d;
  const std::string model_name = design_model_name(opt.model);
  out.dwell = dwell_for(out.chosen, model_name, target, settings, max_repeats);
  out.paper = dwell_for(paper9(), model_name, target, settings, max_repeats);
  return out;
}

json optimized_json(const OptimizeOutcome& r, const OptimizeCliOptions& o,
                    const DesignSettings& settings) {
  json j = {{"program", r.chosen.name},
            {"model", design_model_name(r.model)},
            {"structure", o.structure.empty() ? "none" : o.structure},
            {"positions", positions_json(r.chosen, r.dwell.allocated.dwell_s)},
            {"positions_chosen_for", r.polished() ? "the wander" : "white noise"},
            {"d_criterion", r.chosen_d},
            {"paper9_d_criterion", r.white.paper9_d_criterion},
            {"gain_vs_paper9", r.gain()},
            {"gain_per_position_vs_paper9", r.per_position_gain()},
            {"noise_density_ug_rthz", settings.noise_density_ug_rthz},
            {"dwell_for_target", dwell_json(r.dwell)},
            {"paper9_dwell_for_target", dwell_json(r.paper)}};
  if (r.polish) j["wander_polish"] = polish_json(*r.polish, r.white.program, r.white_d);
  add_wander_json(j, settings);
  return j;
}

void print_optimized(const OptimizeOutcome& r, bool paper_structure, const AccuracyTarget& target,
                     const DesignSettings& settings) {
  const Program& chosen = r.chosen;
  const std::vector<double>& allocated = r.dwell.allocated.dwell_s;
  std::printf("%s (%s model%s, %zu positions):\n",
              r.polished() ? "Programme moved for the wander from white noise's D-optimum"
                           : "D-optimal programme",
              design_model_name(r.model).c_str(), paper_structure ? ", paper structure" : "",
              chosen.positions.size());
  std::printf("  %3s %11s %11s %12s\n", "pos", "alpha1 deg", "alpha2 deg", "alloc dwell s");
  for (std::size_t k = 0; k < chosen.positions.size(); ++k) {
    const auto& p = chosen.positions[k];
    std::printf("  %3zu %11.3f %11.3f %12.1f\n", k + 1, p.alpha1_deg, p.alpha2_deg,
                k < allocated.size() ? allocated[k] : 0.0);
  }
  std::printf("\nD-criterion det^(1/9) = %.5f; paper9: %.5f; gain %+.1f %%\n", r.chosen_d,
              r.white.paper9_d_criterion, 100 * (r.gain() - 1));
  if (settings.wander()) print_polish(r.polish, r.white_d);
  if (chosen.positions.size() != paper9().positions.size())
    std::printf(
        "  per position (information per measurement, fair for different counts): %+.1f %%\n",
        100 * (r.per_position_gain() - 1));
  std::printf("\n");
  print_dwell_header(target, settings);
  print_dwell_row(r.paper);
  print_dwell_row(r.dwell);
}

void run_optimize(const OptimizeCliOptions& o) {
  const DesignSettings settings = settings_of(o.flags);
  const OptimizeOptions opt = optimize_options_of(o);
  const AccuracyTarget target = parse_accuracy_target(o.target);
  const OptimizeOutcome r = optimize(opt, target, settings, o.max_repeats);
  const std::string written =
      o.program_out.empty() ? ""
                            : write_optimized_program(r.chosen, r.dwell, settings, o.program_out);
  if (o.flags.json) {
    print_json(optimized_json(r, o, settings));
    return;
  }
  print_optimized(r, opt.paper_structure, target, settings);
  if (!written.empty()) std::printf("\n%s\n", written.c_str());
}

void run_compare(const CompareOptions& o) {
  const DesignSettings settings = settings_of(o.flags);
  const AccuracyTarget target = parse_accuracy_target(o.target);
  StandLimits limits;
  if (!o.flags.limits.empty())
    limits = parse_limits(o.flags.limits);
  else
    limits.alpha1.continuous = limits.alpha2.continuous = true;
  std::vector<Program> programs;
  for (const auto& name : o.programs) programs.push_back(load_program(name));
  if (o.with_optimal > 0) {
    OptimizeOptions opt;
    opt.positions = o.with_optimal;
    opt.limits = limits;
    opt.model = optimized_model(o.flags.model);
    const Program white_optimum = optimize_program(opt).program;
    // As `design optimize` chooses it: under a wander, moved for it.
    const std::optional<WanderPolish> moved =
        moved_for_wander(opt, white_optimum, target, settings, o.max_repeats);
    programs.push_back(moved ? moved->program : white_optimum);
  }
  std::vector<ProgrammeDwell> rows;
  for (const auto& p : programs)
    rows.push_back(dwell_for(p, o.flags.model, target, settings, o.max_repeats));
  std::map<DesignModel, double> bound;
  for (const auto& r : rows)
    if (!bound.count(r.model))
      bound[r.model] = continuous_lower_bound_s(r.model, target, settings, limits);

  if (o.flags.json) {
    json j = {{"target",
               {{"bias_ug", target.bias_ug},
                {"scale_ppm", target.scale_ppm},
                {"gamma_arcsec", target.gamma_arcsec}}},
              {"noise_density_ug_rthz", settings.noise_density_ug_rthz}};
    add_wander_json(j, settings);
    for (const auto& r : rows) j["programs"].push_back(dwell_json(r));
    for (const auto& [m, s] : bound) j["lower_bound_total_dwell_s"][design_model_name(m)] = s;
    print_json(j);
    return;
  }
  print_dwell_header(target, settings);
  for (const auto& r : rows) print_dwell_row(r);
  std::printf(
      "\nlower bound (continuous optimal design over the stand's reachable poses, one mount%s):\n",
      settings.wander() ? "; white noise only: a continuous design has no time order for the "
                          "wander"
                        : "");
  for (const auto& [m, s] : bound)
    std::printf("  %-9s model: %.1f s of total dwell\n", design_model_name(m).c_str(), s);
  for (const auto& r : rows)
    if (!r.note.empty()) std::printf("note: %s\n", r.note.c_str());
  std::printf(
      "(bench= / bench~: total bench time with equal / allocated dwells, moves, settle and "
      "re-mounts)\n");
  if (settings.wander())
    std::printf(
        "(a revisit plan as a programme file: standcal design evaluate PROGRAMME --repeat N "
        "--dwell-s S -o FILE)\n");
}

void add_design_commands(CLI::App& app) {
  CLI::App* design =
      app.add_subcommand("design", "experiment design: evaluate, optimise and compare programmes");
  design->require_subcommand(1);

  auto ev = std::make_shared<EvaluateOptions>();
  CLI::App* evaluate = design->add_subcommand(
      "evaluate", "predicted accuracy, criteria and bench time of a programme");
  evaluate->add_option("program", ev->program, "paper9, classic24 or a programme JSON file")
      ->required();
  evaluate
      ->add_option("--dwell-s", ev->flags.settings.dwell_s,
                   "dwell per position unless the programme says")
      ->check(cli_checks::kPositive)
      ->capture_default_str();
  evaluate
      ->add_option("--repeat", ev->repeat,
                   "visit the programme's positions this many times in a row (see `design "
                   "compare --bias-instability-ug`)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  evaluate->add_option("-o,--program-out", ev->program_out,
                       "write the programme evaluated (repeats and dwells included) as JSON");
  add_design_flags(evaluate, ev->flags);
  evaluate->callback([ev] { run_evaluate(*ev); });

  auto op = std::make_shared<OptimizeCliOptions>();
  CLI::App* optimize =
      design->add_subcommand("optimize", "D-optimal programme over the stand's reachable angles");
  optimize->add_option("--positions", op->positions, "number of positions")->capture_default_str();
  optimize->add_option("--structure", op->structure,
                       "paper: 5 at alpha2=0, 3 at alpha1=0, one at (45, 90)");
  optimize->add_option("--restarts", op->restarts, "random starts of the exchange algorithm")
      ->capture_default_str();
  optimize->add_option("--seed", op->seed, "seed of the random starts")->capture_default_str();
  optimize->add_option("--target", op->target, "target 1 sigma for the dwell allocation")
      ->capture_default_str();
  optimize->add_option("-o,--program-out", op->program_out,
                       "write the programme (with allocated dwells) as JSON");
  add_max_repeats(optimize, op->max_repeats);
  add_design_flags(optimize, op->flags);
  optimize->callback([op] { run_optimize(*op); });

  auto cp = std::make_shared<CompareOptions>();
  CLI::App* compare =
      design->add_subcommand("compare", "dwell and bench time each programme needs for a target");
  compare->add_option("programs", cp->programs, "paper9, classic24 or programme JSON files")
      ->required();
  compare
      ->add_option("--target", cp->target, "target 1 sigma, e.g. bias=2ug,scale=2ppm,gamma=1asec")
      ->capture_default_str();
  compare->add_option("--with-optimal", cp->with_optimal,
                      "also the D-optimal programme with this many positions");
  add_max_repeats(compare, cp->max_repeats);
  add_design_flags(compare, cp->flags);
  compare->callback([cp] { run_compare(*cp); });
}

}  // namespace

static const bool design_commands_registered = register_command_group(add_design_commands);

}  // namespace standcal::cli
