#include "calib/programs.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "calib/text.hpp"

namespace standcal {

namespace {

// Table 2 of the paper (rounded from the D-optimal 57.47 and 122.53 deg of model.md).
constexpr double kPaperAlpha2Deg[3] = {57.5, 122.5, 270.0};

ProgramPosition at(double alpha1_deg, double alpha2_deg, Mount mount = Mount::x) {
  ProgramPosition p;
  p.alpha1_deg = alpha1_deg;
  p.alpha2_deg = alpha2_deg;
  p.mount = mount;
  return p;
}

std::string position_label(const std::string& source, std::size_t index, std::size_t count) {
  return source + ": position " + std::to_string(index + 1) + " of " + std::to_string(count);
}

void require_at_most(double value, double limit, const char* key, const std::string& where) {
  if (value > limit) {
    const auto [value_text, limit_text] = number_texts_apart(value, limit);
    throw ProgramError(where + ": '" + key + "' must be at most " + limit_text +
                       " s (the run limit), not " + value_text);
  }
}

double require_number(const nlohmann::json& p, const char* key, const std::string& where) {
  if (!p.contains(key)) throw ProgramError(where + ": '" + key + "' is missing");
  if (!p.at(key).is_number()) throw ProgramError(where + ": '" + key + "' must be a number");
  const double v = p.at(key).get<double>();
  if (!std::isfinite(v)) throw ProgramError(where + ": '" + key + "' must be finite");
  return v;
}

ProgramPosition position_from_json(const nlohmann::json& p, const std::string& where) {
  static const std::set<std::string> kKeys{"alpha1_deg", "alpha2_deg", "mount", "dwell_s",
                                           "settle_s"};
  if (!p.is_object()) throw ProgramError(where + ": must be an object");
  for (const auto& item : p.items())
    if (!kKeys.count(item.key()))
      throw ProgramError(where + ": unknown key '" + item.key() +
                         "' (known: alpha1_deg, alpha2_deg, mount, dwell_s, settle_s)");
  ProgramPosition pos;
  pos.alpha1_deg = require_number(p, "alpha1_deg", where);
  pos.alpha2_deg = require_number(p, "alpha2_deg", where);
  if (p.contains("mount")) {
    if (!p["mount"].is_string() || !parse_mount(p["mount"].get<std::string>(), pos.mount))
      throw ProgramError(where + ": 'mount' must be \"x\", \"y\" or \"z\"");
  }
  if (p.contains("dwell_s")) {
    pos.dwell_s = require_number(p, "dwell_s", where);
    if (*pos.dwell_s <= 0) throw ProgramError(where + ": 'dwell_s' must be > 0");
    require_at_most(*pos.dwell_s, kMaxDwell_s, "dwell_s", where);
  }
  if (p.contains("settle_s")) {
    pos.settle_s = require_number(p, "settle_s", where);
    if (*pos.settle_s < 0) throw ProgramError(where + ": 'settle_s' must be >= 0");
    require_at_most(*pos.settle_s, kMaxSettle_s, "settle_s", where);
  }
  return pos;
}

// The programme object's own keys: a misspelt one ("dwel_s") must not be ignored.
void require_known_programme_keys(const nlohmann::json& doc, const std::string& source) {
  for (const auto& item : doc.items())
    if (item.key() != "name" && item.key() != "positions" && item.key() != "warmup_s")
      throw ProgramError(source + ": unknown key '" + item.key() +
                         "' (known: name, positions, warmup_s)");
}

// The first position's warm-up before its dwell (Program::warmup_s).
double programme_warmup_s(const nlohmann::json& doc, const std::string& source) {
  if (!doc.contains("warmup_s")) return 0;
  const double warmup_s = require_number(doc, "warmup_s", source);
  if (warmup_s < 0) throw ProgramError(source + ": 'warmup_s' must be >= 0");
  require_at_most(warmup_s, kMaxDwell_s, "warmup_s", source);
  return warmup_s;
}

// The name goes into the recording header, run.json and reports: one printable line.
std::string programme_name(const nlohmann::json& doc, const std::string& source) {
  if (!doc.contains("name")) return "custom";
  if (!doc["name"].is_string()) throw ProgramError(source + ": 'name' must be a string");
  const std::string name = doc["name"].get<std::string>();
  if (const auto c = find_control_character(name))
    throw ProgramError(source + ": 'name' must be printable text on one line: it contains " +
                       describe(*c));
  return name;
}

}  // namespace

std::vector<std::size_t> Program::remount_before() const {
  std::vector<std::size_t> steps;
  for (std::size_t i = 1; i < positions.size(); ++i)
    if (positions[i].mount != positions[i - 1].mount) steps.push_back(i);
  return steps;
}

Program paper9(double alpha1_start_deg, int position9_n) {
  Program p;
  p.name = "paper9";
  for (int k = 0; k < 5; ++k) p.positions.push_back(at(alpha1_start_deg + 72.0 * k, 0.0));
  for (double a2 : kPaperAlpha2Deg) p.positions.push_back(at(0.0, a2));
  p.positions.push_back(at(45.0 + 90.0 * position9_n, 90.0));
  return p;
}

Program classic24() {
  Program p;
  p.name = "classic24";
  for (Mount m : {Mount::x, Mount::y, Mount::z})
    for (double a1 : {90.0, 270.0})
      for (double a2 : {0.0, 90.0, 180.0, 270.0}) p.positions.push_back(at(a1, a2, m));
  return p;
}

Program program_from_json(const nlohmann::json& doc, const std::string& source) {
  if (!doc.is_object() || !doc.contains("positions") || !doc["positions"].is_array())
    throw ProgramError(source + ": a programme is an object with a 'positions' array");
  require_known_programme_keys(doc, source);
  Program p;
  p.name = programme_name(doc, source);
  p.warmup_s = programme_warmup_s(doc, source);
  const auto& list = doc["positions"];
  if (list.empty()) throw ProgramError(source + ": 'positions' is empty");
  for (std::size_t i = 0; i < list.size(); ++i)
    p.positions.push_back(position_from_json(list[i], position_label(source, i, list.size())));
  return p;
}

Program load_program(const std::string& name_or_path, double paper9_alpha1_start_deg) {
  if (name_or_path == "paper9") return paper9(paper9_alpha1_start_deg);
  if (name_or_path == "classic24") return classic24();
  std::error_code ec;  // a directory reads as "basic_filebuf::underflow", naming nothing
  if (std::filesystem::is_directory(name_or_path, ec))
    throw ProgramError(name_or_path + ": is a directory, not a programme file");
  std::ifstream in(name_or_path);
  if (!in)
    throw ProgramError(name_or_path +
                       ": not a built-in programme (paper9, classic24) nor a readable file");
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw ProgramError(name_or_path + ": not valid JSON (" + e.what() + ")");
  }
  return program_from_json(doc, name_or_path);
}

nlohmann::json program_to_json(const Program& program) {
  nlohmann::json positions = nlohmann::json::array();
  for (const auto& p : program.positions) {
    nlohmann::json j{
        {"alpha1_deg", p.alpha1_deg}, {"alpha2_deg", p.alpha2_deg}, {"mount", mount_name(p.mount)}};
    if (p.dwell_s) j["dwell_s"] = *p.dwell_s;
    if (p.settle_s) j["settle_s"] = *p.settle_s;
    positions.push_back(j);
  }
  nlohmann::json out{{"name", program.name}, {"positions", positions}};
  if (program.warmup_s > 0) out["warmup_s"] = program.warmup_s;
  return out;
}

std::vector<double> axis_grid_deg(const AxisRange& range, double step_deg) {
  std::vector<double> out;
  const double lo = range.continuous ? -180.0 : range.min_deg;
  const double hi = range.continuous ? 180.0 : range.max_deg;
  for (double a = lo; a < hi - 1e-9; a += step_deg) out.push_back(a);
  if (!range.continuous) out.push_back(hi);
  return out;
}

std::optional<double> normalise_angle_deg(double angle_deg, const AxisRange& range) {
  const bool inside = angle_deg >= range.min_deg && angle_deg <= range.max_deg;
  return equivalent_angle_deg(range, angle_deg, inside ? angle_deg : range.middle_deg());
}

Program normalise_program(const Program& program, const StandLimits& limits) {
  Program out = program;
  const std::size_t n = program.positions.size();
  for (std::size_t i = 0; i < n; ++i) {
    auto& p = out.positions[i];
    const auto a1 = normalise_angle_deg(p.alpha1_deg, limits.alpha1);
    const auto a2 = normalise_angle_deg(p.alpha2_deg, limits.alpha2);
    // The angle as the programme wrote it: one just past an end reads as past it (90.00001,
    // not 90, outside [-90, 90]).
    const auto outside_text = [&](const char* name, double angle_deg, const AxisRange& r,
                                  const char* axis) {
      return position_label(program.name, i, n) + ": " + name + " = " + round_trip_text(angle_deg) +
             " deg has no equivalent angle in the " + axis + " axis range [" +
             round_trip_text(r.min_deg) + ", " + round_trip_text(r.max_deg) + "] deg";
    };
    if (!a1) throw ProgramError(outside_text("alpha1", p.alpha1_deg, limits.alpha1, "outer"));
    if (!a2) throw ProgramError(outside_text("alpha2", p.alpha2_deg, limits.alpha2, "inner"));
    p.alpha1_deg = *a1;
    p.alpha2_deg = *a2;
  }
  return out;
}

}  // namespace standcal
