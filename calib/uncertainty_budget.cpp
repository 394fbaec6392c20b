#include "calib/uncertainty_budget.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "calib/averaging.hpp"
#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/model.hpp"
#include "calib/noise_model.hpp"

namespace standcal {

using nlohmann::json;

namespace {

// How a type B input changes the measurements: the averages as they would have been had
// the input been x (internal units) instead of its nominal 0.
using Perturbation = std::function<void(std::vector<PositionAverage>&, double x)>;

struct InputModel {
  BudgetInput input;
  Perturbation perturb;
};

// The unit the fit found, as the forward model's UnitErrors (unobservable parameters 0).
UnitErrors budget_fitted_unit(const FitResult& fit) {
  Eigen::Matrix<double, 9, 1> p = Eigen::Matrix<double, 9, 1>::Zero();
  for (int j = 0; j < kUnitParameterCount; ++j)
    p[j] = fit.unit[static_cast<std::size_t>(j)].value.value_or(0.0);
  return UnitErrors::from_parameters(p);
}

// A stand or mounting error: each mean moves by the forward model's J(error = x) - J(0).
Perturbation stand_error_effect(const UnitErrors& unit,
                                std::function<void(StandErrors&, double)> set) {
  return [unit, set](std::vector<PositionAverage>& averages, double x) {
    StandErrors perturbed;
    set(perturbed, x);
    for (PositionAverage& a : averages) {
      const double a1 = a.alpha1_cmd_deg * kDegToRad;
      const double a2 = a.alpha2_cmd_deg * kDegToRad;
      a.mean_g += unit_output_g(unit, true_up_vector(a1, a2, a.mount, perturbed)) -
                  unit_output_g(unit, true_up_vector(a1, a2, a.mount, StandErrors{}));
    }
  };
}

// Local gravity: the means are f / g_used; had g been g_used + x they would be f / (g_used + x).
Perturbation gravity_error_effect(double g_used_mps2) {
  return [g_used_mps2](std::vector<PositionAverage>& averages, double x) {
    for (PositionAverage& a : averages) a.mean_g *= g_used_mps2 / (g_used_mps2 + x);
  };
}

// A temperature coefficient x of axis `axis` (bias: g/degC; scale: 1/degC, times the
// gravity component along the axis): each dwell moves by x (T - T_ref).
Perturbation temperature_error_effect(int axis, bool scale, double t_ref_c) {
  return [axis, scale, t_ref_c](std::vector<PositionAverage>& averages, double x) {
    for (PositionAverage& a : averages) {
      if (std::isnan(a.temp_mean_c)) continue;
      const double along = scale ? a.up()[axis] : 1.0;
      a.mean_g[axis] += x * (a.temp_mean_c - t_ref_c) * along;
    }
  };
}

BudgetInput rectangular_input(std::string name, std::string source, double bound, std::string unit,
                              double to_internal) {
  return {std::move(name), std::move(source), Distribution::rectangular,           bound,
          std::move(unit), to_internal,       bound * to_internal / std::sqrt(3.0)};
}

// Each re-seating of a re-mounted programme's fixture: one input per mount and axis, that
// mount's rotation alone (the seating common to all mounts is mounting_arcsec).
void add_remount_inputs(const BudgetConfig& c, const std::string& source, const UnitErrors& unit,
                        const std::vector<PositionAverage>& positions, std::vector<InputModel>& out,
                        std::vector<std::string>& missing) {
  std::set<Mount> mounts;
  for (const PositionAverage& a : positions) mounts.insert(a.mount);
  if (mounts.size() < 2) return;
  if (std::isnan(c.remount_arcsec)) {
    missing.push_back(
        "stand.remount_arcsec (not in the budget file; this programme re-mounts the unit, and "
        "a fit that takes one rigid fixture puts each re-seating into the gamma pair sums)");
    return;
  }
  for (const Mount m : mounts) {
    for (int axis = 0; axis < 3; ++axis) {
      out.push_back(
          {rectangular_input("mount " + mount_name(m) + " re-seating about " + "xyz"[axis], source,
                             c.remount_arcsec, "arcsec", kArcsecToRad),
           stand_error_effect(unit, [m, axis](StandErrors& s, double x) {
             s.mounting_rad[static_cast<std::size_t>(m)][axis] = x;
           })});
    }
  }
}

void add_stand_inputs(const BudgetConfig& c, const UnitErrors& unit,
                      const std::vector<PositionAverage>& positions, std::vector<InputModel>& out,
                      std::vector<std::string>& missing) {
  const std::string source = c.stand_source.empty() ? c.source : c.stand_source;
  using Set = std::function<void(StandErrors&, double)>;
  const auto add = [&](double bound, const char* key,
                       std::vector<std::pair<std::string, Set>> parts) {
    if (std::isnan(bound)) {
      missing.push_back(std::string("stand.") + key + " (not in the budget file)");
      return;
    }
    for (auto& [name, set] : parts) {
      out.push_back({rectangular_input(name, source, bound, "arcsec", kArcsecToRad),
                     stand_error_effect(unit, set)});
    }
  };
  add(c.angle_zero_arcsec, "angle_zero_arcsec",
      {{"outer-axis angle zero", [](StandErrors& s, double x) { s.alpha1_offset_rad = x; }},
       {"inner-axis angle zero", [](StandErrors& s, double x) { s.alpha2_offset_rad = x; }}});
  add(c.orthogonality_arcsec, "orthogonality_arcsec",
      {{"axes' orthogonality about y", [](StandErrors& s, double x) { s.skew_y_rad = x; }},
       {"axes' orthogonality about z", [](StandErrors& s, double x) { s.skew_z_rad = x; }}});
  add(c.level_arcsec, "level_arcsec",
      {{"stand level about x", [](StandErrors& s, double x) { s.levelling_x_rad = x; }},
       {"stand level about z", [](StandErrors& s, double x) { s.levelling_z_rad = x; }}});
  std::vector<std::pair<std::string, Set>> mounting;
  for (int axis = 0; axis < 3; ++axis) {
    mounting.emplace_back(std::string("unit mounting about ") + "xyz"[axis],
                          [axis](StandErrors& s, double x) {
                            for (Vec3& m : s.mounting_rad) m[axis] = x;
                          });
  }
  add(c.mounting_arcsec, "mounting_arcsec", std::move(mounting));
  add_remount_inputs(c, source, unit, positions, out, missing);
}

void add_temperature_inputs(const BudgetConfig& c, const std::string& unit_type,
                            const std::vector<PositionAverage>& positions,
                            std::vector<InputModel>& out, std::vector<std::string>& missing) {
  const std::optional<double> t_ref = mean_dwell_temperature_c(positions);
  if (unit_type.empty() && !c.unit_types.empty()) {
    missing.push_back(
        "temperature: the unit type is not known (no unit_type for this run), so no coefficients "
        "apply");
    return;
  }
  const auto type = c.unit_types.find(unit_type);
  if (type == c.unit_types.end()) {
    missing.push_back("temperature: no coefficients for unit type '" + unit_type +
                      "' in the budget file");
    return;
  }
  if (!t_ref) {
    missing.push_back("temperature: the recording has no temperatures");
    return;
  }
  const std::string source = c.source + ", unit type " + unit_type;
  for (int axis = 0; axis < 3; ++axis) {
    const std::string a(1, "xyz"[axis]);
    if (!std::isnan(type->second.bias_ug_per_c)) {
      out.push_back({rectangular_input("bias temperature coefficient " + a, source,
                                       type->second.bias_ug_per_c, "ug/degC", kUg),
                     temperature_error_effect(axis, false, *t_ref)});
    }
    if (!std::isnan(type->second.scale_ppm_per_c)) {
      out.push_back({rectangular_input("scale temperature coefficient " + a, source,
                                       type->second.scale_ppm_per_c, "ppm/degC", kPpm),
                     temperature_error_effect(axis, true, *t_ref)});
    }
  }
}

std::vector<InputModel> budget_input_models(const std::vector<PositionAverage>& positions,
                                            const FitResult& fit, const BudgetConfig& c,
                                            const std::string& unit_type, double g_mps2,
                                            std::vector<std::string>& missing) {
  std::vector<InputModel> inputs;
  add_stand_inputs(c, budget_fitted_unit(fit), positions, inputs, missing);
  if (std::isnan(c.g_standard_uncertainty_mps2)) {
    missing.push_back("gravity.standard_uncertainty_mps2 (not in the budget file)");
  } else {
    inputs.push_back(
        {{"local gravity", c.g_source.empty() ? c.source : c.g_source, Distribution::normal,
          c.g_standard_uncertainty_mps2, "m/s^2", 1.0, c.g_standard_uncertainty_mps2},
         gravity_error_effect(g_mps2)});
  }
  add_temperature_inputs(c, unit_type, positions, inputs, missing);
  return inputs;
}

// E[x^4] / u^4 of the input's distribution: what the second-order term's square weighs.
double fourth_moment_ratio(Distribution d) { return d == Distribution::normal ? 3.0 : 1.8; }

// GUM's u_A is the scale s of the t distribution; the fit's sigma is its standard
// deviation, s times student_t_inflation(nu), so that sigma has z-variance 1.
double gum_type_a_of(const ParameterEstimate& p) {
  return p.sigma.value_or(0.0) / student_t_inflation(p.dof);
}

void combine_budget(ParameterBudget& b) {
  double var = b.type_a * b.type_a;
  for (double c : b.contribution) var += c * c;
  b.combined = std::sqrt(var);
  // Welch-Satterthwaite: type B bounds are taken as exact (GUM G.4.2), infinite dof.
  const double a4 = std::pow(b.type_a, 4);
  b.dof_effective = std::isfinite(b.type_a_dof) && a4 > 0 ? var * var / (a4 / b.type_a_dof)
                                                          : std::numeric_limits<double>::infinity();
  b.coverage_factor = student_t_975(b.dof_effective);
  b.expanded = b.coverage_factor * b.combined;
}

std::string budget_distribution_name(Distribution d) {
  return d == Distribution::normal ? "normal" : "rectangular";
}

double budget_number(const json& obj, const char* key, const std::string& where) {
  if (!obj.contains(key)) return kNaN;
  const json& v = obj.at(key);
  if (!v.is_number() || v.get<double>() < 0 || !std::isfinite(v.get<double>())) {
    throw BudgetConfigError(where + "." + key + ": must be a number >= 0 (got " + v.dump() + ")");
  }
  return v.get<double>();
}

void budget_only_keys(const json& obj, const std::string& where,
                      std::initializer_list<const char*> keys) {
  if (!obj.is_object()) throw BudgetConfigError(where + ": must be an object");
  for (const auto& [key, value] : obj.items()) {
    bool known = false;
    for (const char* k : keys) known = known || key == k;
    if (!known) throw BudgetConfigError(where + "." + key + ": unknown key");
  }
}

std::string budget_text(const json& obj, const char* key, const std::string& where) {
  if (!obj.contains(key)) return "";
  if (!obj.at(key).is_string()) throw BudgetConfigError(where + "." + key + ": must be text");
  return obj.at(key).get<std::string>();
}

}  // namespace

FitNoiseOptions frozen_noise(const NoiseFinding& noise) {
  FitNoiseOptions o;
  if (noise.model != "gauss_markov") return white_noise_weighting();
  o.mode = FitNoiseOptions::Mode::specified;
  o.specified.q_g = noise.wander_ug * kUg;
  o.specified.tau_s = noise.tau_s;
  return o;
}

Estimator budget_estimator(const std::string& method, const FitResult& nominal,
                           MountingModel mounting) {
  const FitNoiseOptions noise = frozen_noise(nominal.noise);
  if (method == "full") {
    FullFitOptions options;
    options.noise = noise;
    options.mounting = mounting;
    return [options](const std::vector<PositionAverage>& a) { return fit_full_vector(a, options); };
  }
  if (method == "paper-sequential")
    return [](const std::vector<PositionAverage>& a) { return fit_paper_sequential(a); };
  if (method == "joint")
    return [noise](const std::vector<PositionAverage>& a) { return fit_invariant_joint(a, noise); };
  throw std::invalid_argument("budget_estimator: unknown method " + method);
}

UncertaintyBudget evaluate_budget(const std::vector<PositionAverage>& positions,
                                  const FitResult& fit, const Estimator& estimator,
                                  const BudgetConfig& config, const std::string& unit_type,
                                  double g_local_mps2) {
  UncertaintyBudget budget;
  budget.estimator = fit.estimator;
  const std::vector<InputModel> models =
      budget_input_models(positions, fit, config, unit_type, g_local_mps2, budget.not_budgeted);
  for (const InputModel& m : models) budget.inputs.push_back(m.input);
  for (int j = 0; j < kUnitParameterCount; ++j) {
    ParameterBudget& b = budget.parameters[static_cast<std::size_t>(j)];
    const ParameterEstimate& p = fit.unit[static_cast<std::size_t>(j)];
    b.parameter = j;
    b.observable = p.value.has_value();
    b.type_a = gum_type_a_of(p);
    b.type_a_dof = p.dof;
  }
  // Each input at +-u through the estimator: the first derivative from the difference, the
  // second from the sum (the invariant measurement is first-order blind to rotations of
  // the stand, so for it the stand's inputs act at second order only).
  for (const InputModel& m : models) {
    const double u = m.input.standard_uncertainty;
    std::vector<PositionAverage> up = positions, down = positions;
    m.perturb(up, u);
    m.perturb(down, -u);
    const FitResult f_up = estimator(up);
    const FitResult f_down = estimator(down);
    for (int j = 0; j < kUnitParameterCount; ++j) {
      const std::size_t i = static_cast<std::size_t>(j);
      ParameterBudget& b = budget.parameters[i];
      const double v0 = fit.unit[i].value.value_or(0.0);
      const double vu = f_up.unit[i].value.value_or(v0);
      const double vd = f_down.unit[i].value.value_or(v0);
      const double linear = (vu - vd) / 2;          // c u
      const double quadratic = (vu + vd) / 2 - v0;  // (1/2) f'' u^2
      b.sensitivity.push_back(u > 0 ? linear / u : 0.0);
      b.second_order.push_back(quadratic);
      b.contribution.push_back(std::sqrt(
          linear * linear + fourth_moment_ratio(m.input.distribution) * quadratic * quadratic));
    }
  }
  for (ParameterBudget& b : budget.parameters) combine_budget(b);
  return budget;
}

BudgetConfig budget_config_from_json(const json& doc, const std::string& source) {
  BudgetConfig c;
  c.source = source;
  budget_only_keys(doc, source, {"format", "stand", "gravity", "unit_types"});
  if (!doc.contains("format") || doc["format"] != kBudgetFormat) {
    throw BudgetConfigError(source + ": format: must be \"" + kBudgetFormat + "\"");
  }
  if (doc.contains("stand")) {
    const json& s = doc["stand"];
    const std::string where = source + ": stand";
    budget_only_keys(s, where,
                     {"source", "angle_zero_arcsec", "orthogonality_arcsec", "level_arcsec",
                      "mounting_arcsec", "remount_arcsec"});
    c.stand_source = budget_text(s, "source", where);
    c.angle_zero_arcsec = budget_number(s, "angle_zero_arcsec", where);
    c.orthogonality_arcsec = budget_number(s, "orthogonality_arcsec", where);
    c.level_arcsec = budget_number(s, "level_arcsec", where);
    c.mounting_arcsec = budget_number(s, "mounting_arcsec", where);
    c.remount_arcsec = budget_number(s, "remount_arcsec", where);
  }
  if (doc.contains("gravity")) {
    const json& g = doc["gravity"];
    const std::string where = source + ": gravity";
    budget_only_keys(g, where, {"standard_uncertainty_mps2", "source"});
    c.g_standard_uncertainty_mps2 = budget_number(g, "standard_uncertainty_mps2", where);
    c.g_source = budget_text(g, "source", where);
  }
  if (doc.contains("unit_types")) {
    if (!doc["unit_types"].is_object())
      throw BudgetConfigError(source + ": unit_types: must be an object");
    for (const auto& [name, t] : doc["unit_types"].items()) {
      const std::string where = source + ": unit_types." + name;
      budget_only_keys(t, where, {"bias_ug_per_c", "scale_ppm_per_c"});
      c.unit_types[name] = {budget_number(t, "bias_ug_per_c", where),
                            budget_number(t, "scale_ppm_per_c", where)};
    }
  }
  return c;
}

BudgetConfig load_budget_config(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw BudgetConfigError(path + ": cannot read it");
  const json doc = json::parse(in, nullptr, false);
  if (doc.is_discarded()) throw BudgetConfigError(path + ": not valid JSON");
  return budget_config_from_json(doc, path);
}

json budget_to_json(const UncertaintyBudget& budget) {
  json inputs = json::array();
  for (const BudgetInput& in : budget.inputs) {
    inputs.push_back(
        {{"name", in.name},
         {"source", in.source},
         {"distribution", budget_distribution_name(in.distribution)},
         {in.distribution == Distribution::normal ? "standard_uncertainty" : "half_width",
          in.stated},
         {"unit", in.stated_unit}});
  }
  json parameters = json::object();
  for (const ParameterBudget& b : budget.parameters) {
    const std::size_t i = static_cast<std::size_t>(b.parameter);
    if (!b.observable) {
      parameters[std::string(kUnitParameterNames[i])] = nullptr;
      continue;
    }
    const double scale = report_scale(b.parameter);
    json contributions = json::array();
    for (std::size_t k = 0; k < b.contribution.size(); ++k) {
      const BudgetInput& in = budget.inputs[k];
      contributions.push_back(
          {{"input", in.name},
           {"sensitivity", b.sensitivity[k] * scale * in.to_internal},
           {"sensitivity_unit", std::string(kUnitParameterUnits[i]) + " per " + in.stated_unit},
           {"second_order", b.second_order[k] * scale},
           {"u", b.contribution[k] * scale}});
    }
    const auto dof = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
    parameters[std::string(kUnitParameterNames[i])] = {
        {"unit", std::string(kUnitParameterUnits[i])},
        {"type_a", {{"u", b.type_a * scale}, {"dof", dof(b.type_a_dof)}}},
        {"type_b", contributions},
        {"combined_u", b.combined * scale},
        {"dof_effective", dof(b.dof_effective)},
        {"coverage_factor", b.coverage_factor},
        {"expanded_U", b.expanded * scale}};
  }
  return {{"format", "GUM (JCGM 100:2008)"},
          {"estimator", budget.estimator},
          {"coverage_probability", budget.coverage_probability},
          {"inputs", inputs},
          {"not_budgeted", budget.not_budgeted},
          {"parameters", parameters}};
}

std::string format_budget_summary(const UncertaintyBudget& budget) {
  std::string out = "\nUncertainty budget (GUM; type A the fit, type B " +
                    std::to_string(budget.inputs.size()) + " inputs; U for 95 %):\n";
  char line[160];
  for (const ParameterBudget& b : budget.parameters) {
    if (!b.observable) continue;
    const double scale = report_scale(b.parameter);
    const std::size_t i = static_cast<std::size_t>(b.parameter);
    char dof[32] = "inf";
    if (std::isfinite(b.dof_effective) && b.dof_effective < 1e6) {
      std::snprintf(dof, sizeof dof, "%.0f", b.dof_effective);
    }
    std::snprintf(
        line, sizeof line, "  %-8s u_A %8.3f  u_c %8.3f  nu_eff %6s  k %.3f  U %8.3f %s\n",
        std::string(kUnitParameterNames[i]).c_str(), b.type_a * scale, b.combined * scale, dof,
        b.coverage_factor, b.expanded * scale, std::string(kUnitParameterUnits[i]).c_str());
    out += line;
  }
  for (const std::string& m : budget.not_budgeted) out += "  not budgeted: " + m + "\n";
  return out;
}

}  // namespace standcal
