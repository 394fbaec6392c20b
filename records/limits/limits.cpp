#include "records/limits/limits.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "calib/text.hpp"

namespace standcal::records {

namespace {

using nlohmann::json;

// The per-axis parameter names, and the group names that set all three axes at once.
constexpr std::array<std::string_view, 3> kGroupNames{"bias", "scale", "gamma"};

[[noreturn]] void bad_key(const std::string& source, const std::string& key,
                          const std::string& why) {
  throw std::runtime_error(source + ": " + key + ": " + why);
}

std::string shown(const json& value) {
  std::string text = value.dump();
  return text.size() > 40 ? text.substr(0, 37) + "..." : text;
}

void require_object(const json& j, const std::string& source, const std::string& key) {
  if (!j.is_object()) bad_key(source, key, "must be a JSON object (got " + shown(j) + ")");
}

double positive_number(const json& j, const std::string& source, const std::string& key) {
  if (!j.is_number() || !std::isfinite(j.get<double>()) || j.get<double>() <= 0)
    bad_key(source, key, "must be a positive number (got " + shown(j) + ")");
  return j.get<double>();
}

void reject_unknown_keys(const json& obj, std::initializer_list<std::string_view> known,
                         const std::string& source, const std::string& where) {
  for (const auto& [key, value] : obj.items()) {
    bool found = false;
    for (std::string_view k : known) found = found || k == key;
    if (!found) {
      std::string list;
      for (std::string_view k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      bad_key(source, where + key, "unknown key (expected one of: " + list + ")");
    }
  }
}

ParameterLimit parse_parameter_limit(const json& j, const std::string& source,
                                     const std::string& key) {
  require_object(j, source, key);
  reject_unknown_keys(j, {"max_abs", "max_sigma"}, source, key + ".");
  ParameterLimit limit;
  if (j.contains("max_abs"))
    limit.max_abs = positive_number(j["max_abs"], source, key + ".max_abs");
  if (j.contains("max_sigma"))
    limit.max_sigma = positive_number(j["max_sigma"], source, key + ".max_sigma");
  return limit;
}

// An axis key ("bias_x") overrides its group ("bias") field by field.
void merge(ParameterLimit& into, const ParameterLimit& over) {
  if (over.max_abs) into.max_abs = over.max_abs;
  if (over.max_sigma) into.max_sigma = over.max_sigma;
}

std::optional<int> parameter_index(std::string_view name) {
  for (int j = 0; j < kUnitParameterCount; ++j)
    if (kUnitParameterNames[static_cast<std::size_t>(j)] == name) return j;
  return std::nullopt;
}

std::optional<int> group_index(std::string_view name) {
  for (int g = 0; g < 3; ++g)
    if (kGroupNames[static_cast<std::size_t>(g)] == name) return g;
  return std::nullopt;
}

void parse_parameters(const json& j, UnitTypeLimits& limits, const std::string& source,
                      const std::string& key) {
  require_object(j, source, key);
  std::array<ParameterLimit, 3> groups;
  std::array<std::optional<ParameterLimit>, kUnitParameterCount> axes;
  for (const auto& [name, value] : j.items()) {
    const std::string where = key + "." + name;
    if (auto g = group_index(name)) {
      groups[static_cast<std::size_t>(*g)] = parse_parameter_limit(value, source, where);
    } else if (auto p = parameter_index(name)) {
      axes[static_cast<std::size_t>(*p)] = parse_parameter_limit(value, source, where);
    } else {
      bad_key(source, where,
              "unknown parameter (expected bias, scale, gamma or one of bias_x, bias_y, bias_z, "
              "scale_x, "
              "scale_y, scale_z, gamma12, gamma13, gamma23)");
    }
  }
  for (int p = 0; p < kUnitParameterCount; ++p) {
    ParameterLimit& limit = limits.parameters[static_cast<std::size_t>(p)];
    limit = groups[static_cast<std::size_t>(p / 3)];
    if (axes[static_cast<std::size_t>(p)]) merge(limit, *axes[static_cast<std::size_t>(p)]);
  }
}

UnitTypeLimits parse_unit_type(const std::string& name, const json& j, const std::string& source) {
  const std::string key = "unit_types." + name;
  require_object(j, source, key);
  reject_unknown_keys(j, {"description", "parameters", "max_chi2_dof"}, source, key + ".");
  UnitTypeLimits limits;
  limits.unit_type = name;
  if (j.contains("description")) {
    if (!j["description"].is_string()) bad_key(source, key + ".description", "must be a string");
    limits.description = j["description"].get<std::string>();
  }
  if (!j.contains("parameters"))
    bad_key(source, key + ".parameters", "missing (the limits of the unit parameters)");
  parse_parameters(j["parameters"], limits, source, key + ".parameters");
  if (j.contains("max_chi2_dof"))
    limits.max_chi2_dof = positive_number(j["max_chi2_dof"], source, key + ".max_chi2_dof");
  return limits;
}

std::string number(double v, int decimals = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Equal under the limit rule (kLimitTolerance).
bool within_tolerance(double a, double limit) { return negligible_against_limit(a - limit, limit); }

// A value compared plainly with its limit (a σ, a χ²/dof): two decimals when it passed, and
// never said above the limit then; else the digits that show the excess.
NumberTextsApart plain_comparison_texts(double value, double limit, bool passed) {
  if (passed) return {number(std::min(value, limit)), number(limit)};
  return fixed_texts_apart(value, limit, 2);
}

Outcome combine(Outcome a, Outcome b) {
  // Severity order for one parameter: fail > indeterminate (incl. not measured) > pass.
  auto rank = [](Outcome o) {
    switch (o) {
      case Outcome::fail:
        return 4;
      case Outcome::not_evaluated:
        return 3;
      case Outcome::indeterminate:
        return 2;
      case Outcome::pass:
        return 1;
      case Outcome::no_limit:
        return 0;
    }
    return 0;
  };
  return rank(a) >= rank(b) ? a : b;
}

// Report units as a reader writes them.
std::string symbol(const std::string& unit) {
  if (unit == "ug") return "µg";
  if (unit == "arcsec") return "″";
  return unit;
}

std::string coverage_text(double k) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", k);
  return buf;
}

// What decided the outcome against the limit: |v| + U for a pass, |v| - U for a fail, |v|
// for an indeterminate.
double decisive_magnitude(const ParameterConformity& c) {
  const double v = std::abs(*c.value);
  const double U = *c.expanded_uncertainty;
  switch (c.value_decision.outcome) {
    case Outcome::pass:
      return v + U;
    case Outcome::fail:
      return v - U;
    default:
      return v;
  }
}

// Two decimals, or the more that show what decided the outcome apart from the limit
// (|70.004| with U = 10.000 against 60.000: outside by 0.004, where two decimals said
// |70.00| with U = 10.00 against 60.00, outside by 0.00).
int explanation_decimals(const ParameterConformity& c) {
  const double decisive = decisive_magnitude(c);
  if (within_tolerance(decisive, *c.limit.max_abs)) return 2;
  return fixed_decimals_apart(decisive, *c.limit.max_abs, 2);
}

std::string value_explanation(const ParameterConformity& c, double k) {
  const LimitDecision& d = c.value_decision;
  const double limit = *c.limit.max_abs;
  const int decimals = explanation_decimals(c);
  const auto said = [&](double v) { return number(v, decimals); };
  const std::string u = " " + symbol(c.unit);
  const std::string numbers =
      "|" + said(*c.value) + "|" + u + " with U = " + said(*c.expanded_uncertainty) + u +
      " (k = " + coverage_text(k) + ") against the limit " + said(limit) + u;
  switch (d.outcome) {
    case Outcome::pass:
      // Within the rule's tolerance of the limit, none to spare.
      return numbers + ": inside even with the uncertainty added, " +
             said(within_tolerance(decisive_magnitude(c), limit) ? 0.0 : d.guarded_margin) + u +
             " to spare";
    case Outcome::fail:
      return numbers + ": outside even with the uncertainty subtracted, by " +
             said(-(d.margin + *c.expanded_uncertainty)) + u;
    case Outcome::indeterminate:
      if (within_tolerance(std::abs(*c.value), limit))
        return numbers + ": the limit lies within value ± U; the value itself is at the limit";
      return numbers + ": the limit lies within value ± U; the value itself is " +
             (d.value_within_limit ? "inside" : "outside") + " the limit by " +
             said(std::abs(d.margin)) + u;
    default:
      return numbers;
  }
}

ParameterConformity assess_parameter(const FitResult& fit, const UnitTypeLimits& limits, int p,
                                     double k, const UncertaintyBudget* budget) {
  const ParameterEstimate& e = fit.unit[static_cast<std::size_t>(p)];
  ParameterConformity c;
  c.parameter = p;
  c.name = std::string(kUnitParameterNames[static_cast<std::size_t>(p)]);
  c.unit = std::string(kUnitParameterUnits[static_cast<std::size_t>(p)]);
  c.limit = limits.parameters[static_cast<std::size_t>(p)];
  const bool limited = c.limit.max_abs || c.limit.max_sigma;
  if (!e.value || !e.sigma) {
    c.outcome = limited ? Outcome::not_evaluated : Outcome::no_limit;
    c.value_decision.outcome = c.limit.max_abs ? Outcome::not_evaluated : Outcome::no_limit;
    c.sigma_outcome = c.limit.max_sigma ? Outcome::not_evaluated : Outcome::no_limit;
    c.explanation = "not measured by this programme (" + e.unobservable_reason + ")";
    return c;
  }
  c.value = *e.value * report_scale(p);
  c.sigma = std::abs(*e.sigma * report_scale(p));
  c.expanded_uncertainty = k * *c.sigma;
  if (budget != nullptr && budget->parameters[static_cast<std::size_t>(p)].observable) {
    // The GUM budget's combined u and U = k u_c, k from Student's t at its effective dof.
    const ParameterBudget& b = budget->parameters[static_cast<std::size_t>(p)];
    c.sigma = b.combined * report_scale(p);
    c.expanded_uncertainty = b.expanded * report_scale(p);
    k = b.coverage_factor;
  }
  std::vector<std::string> parts;
  if (c.limit.max_abs) {
    c.value_decision = decide(*c.value, *c.expanded_uncertainty, *c.limit.max_abs);
    parts.push_back(value_explanation(c, k));
  }
  if (c.limit.max_sigma) {
    // The uncertainty itself is compared plainly: it has no uncertainty we could add.
    c.sigma_outcome =
        *c.sigma <= *c.limit.max_sigma * (1 + kLimitTolerance) ? Outcome::pass : Outcome::fail;
    // A σ within the check's tolerance of the limit passes, and is said as the limit is.
    const auto [sigma, allowed] =
        plain_comparison_texts(*c.sigma, *c.limit.max_sigma, c.sigma_outcome == Outcome::pass);
    parts.push_back("σ " + sigma + " " + symbol(c.unit) +
                    (c.sigma_outcome == Outcome::pass ? " within" : " EXCEEDS") + " the allowed " +
                    allowed + " " + symbol(c.unit));
  }
  c.outcome = combine(c.value_decision.outcome, c.sigma_outcome);
  for (const std::string& s : parts) c.explanation += (c.explanation.empty() ? "" : "; ") + s;
  return c;
}

ModelCheckConformity assess_model_check(const FitResult& fit, const UnitTypeLimits& limits) {
  ModelCheckConformity m;
  m.max_chi2_dof = limits.max_chi2_dof;
  m.redundancy = fit.redundancy;
  if (fit.redundancy > 0 && std::isfinite(fit.chi2_dof)) m.chi2_dof = fit.chi2_dof;
  if (!m.max_chi2_dof) {
    m.outcome = Outcome::no_limit;
    m.explanation = "no chi2/dof limit set";
  } else if (!m.chi2_dof) {
    m.outcome = Outcome::not_evaluated;
    m.explanation =
        "not evaluated: the programme has no redundant positions, so the fit passes through every "
        "position and cannot show a wrong model";
  } else {
    m.outcome = *m.chi2_dof <= *m.max_chi2_dof ? Outcome::pass : Outcome::fail;
    const auto [chi2_dof, limit] =
        plain_comparison_texts(*m.chi2_dof, *m.max_chi2_dof, m.outcome == Outcome::pass);
    m.explanation = "chi2/dof " + chi2_dof + " with " + std::to_string(m.redundancy) +
                    " degrees of freedom against the limit " + limit +
                    (m.outcome == Outcome::pass
                         ? ": the model describes the data"
                         : ": the residuals exceed the noise, the model misses something");
  }
  return m;
}

std::string overall_sentence(Outcome o) {
  switch (o) {
    case Outcome::pass:
      return "PASS: every limited parameter is inside its limit even after allowing for its "
             "expanded uncertainty.";
    case Outcome::fail:
      return "FAIL: at least one check is outside its limit even after allowing for the "
             "uncertainty.";
    case Outcome::indeterminate:
      return "INDETERMINATE: no check fails, but for at least one parameter the limit lies within "
             "value ± U (or the "
             "parameter was not measured), so conformity cannot be stated. The unit is not "
             "certified as conforming; "
             "re-calibrate with longer dwells or more positions to reduce U.";
    default:
      return "No limits apply: values are reported without a conformity statement.";
  }
}

}  // namespace

const UnitTypeLimits& LimitsConfig::for_unit_type(const std::string& unit_type) const {
  if (unit_type.empty() && unit_types.size() == 1) return unit_types.begin()->second;
  auto it = unit_types.find(unit_type);
  if (it != unit_types.end()) return it->second;
  std::string known;
  for (const auto& [name, limits] : unit_types) known += (known.empty() ? "" : ", ") + name;
  if (unit_type.empty())
    throw std::runtime_error(source + ": several unit types (" + known +
                             "); say which one with --unit-type");
  throw std::runtime_error(source + ": no limits for unit type '" + unit_type +
                           "' (known: " + known + ")");
}

LimitsConfig limits_from_json(const json& doc, const std::string& source) {
  if (!doc.is_object()) throw std::runtime_error(source + ": must be a JSON object");
  reject_unknown_keys(doc, {"format", "coverage_factor", "unit_types"}, source, "");
  if (!doc.contains("format") || doc["format"] != std::string(kLimitsFormat))
    bad_key(source, "format",
            "must be \"" + std::string(kLimitsFormat) + "\"" +
                (doc.contains("format") ? " (got " + shown(doc["format"]) + ")" : " (missing)"));
  LimitsConfig config;
  config.source = source;
  if (doc.contains("coverage_factor"))
    config.coverage_factor = positive_number(doc["coverage_factor"], source, "coverage_factor");
  if (!doc.contains("unit_types"))
    bad_key(source, "unit_types", "missing (one entry per unit type)");
  require_object(doc["unit_types"], source, "unit_types");
  if (doc["unit_types"].empty()) bad_key(source, "unit_types", "must name at least one unit type");
  for (const auto& [name, value] : doc["unit_types"].items())
    config.unit_types.emplace(name, parse_unit_type(name, value, source));
  return config;
}

LimitsConfig load_limits(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the limits file");
  std::stringstream text;
  text << in.rdbuf();
  json doc;
  try {
    doc = json::parse(text.str());
  } catch (const json::parse_error& e) {
    throw std::runtime_error(path + ": not valid JSON (" + e.what() + ")");
  }
  return limits_from_json(doc, path);
}

std::string outcome_name(Outcome o) {
  switch (o) {
    case Outcome::pass:
      return "pass";
    case Outcome::indeterminate:
      return "indeterminate";
    case Outcome::fail:
      return "fail";
    case Outcome::not_evaluated:
      return "not_evaluated";
    case Outcome::no_limit:
      return "no_limit";
  }
  return "no_limit";
}

bool negligible_against_limit(double difference, double limit) {
  return std::abs(difference) <= kLimitTolerance * std::abs(limit);
}

LimitDecision decide(double value, double expanded_uncertainty, double limit) {
  const double tolerance = kLimitTolerance * std::abs(limit);
  const double magnitude = std::abs(value);
  const double U = std::abs(expanded_uncertainty);
  LimitDecision d;
  d.margin = limit - magnitude;
  d.guarded_margin = limit - (magnitude + U);
  d.value_within_limit = magnitude <= limit + tolerance;
  if (magnitude + U <= limit + tolerance)
    d.outcome = Outcome::pass;
  else if (magnitude - U > limit + tolerance)
    d.outcome = Outcome::fail;
  else
    d.outcome = Outcome::indeterminate;
  return d;
}

ConformityReport assess_conformity(const FitResult& fit, const UnitTypeLimits& limits,
                                   double coverage_factor, const std::string& limits_source,
                                   const UncertaintyBudget* budget) {
  ConformityReport r;
  r.unit_type = limits.unit_type;
  r.limits_source = limits_source;
  r.coverage_factor = coverage_factor;
  r.with_budget = budget != nullptr;
  Outcome overall = Outcome::no_limit;
  for (int p = 0; p < kUnitParameterCount; ++p) {
    r.parameters.push_back(assess_parameter(fit, limits, p, coverage_factor, budget));
    overall = combine(overall, r.parameters.back().outcome);
  }
  r.model_check = assess_model_check(fit, limits);
  if (r.model_check.outcome == Outcome::pass || r.model_check.outcome == Outcome::fail)
    overall = combine(overall, r.model_check.outcome);
  // A limited parameter that was not measured cannot be declared conforming.
  r.overall = overall == Outcome::not_evaluated ? Outcome::indeterminate : overall;
  r.overall_text = overall_sentence(r.overall);
  return r;
}

std::string decision_rule_text(double k, bool budget) {
  const std::string how =
      budget ? "each value is reported with its expanded uncertainty U = k·u_c from the GUM "
               "uncertainty budget (σ is "
               "the combined standard uncertainty u_c; k is Student's t for 95 % coverage at each "
               "parameter's "
               "effective degrees of freedom)"
             : "each value is reported with its expanded uncertainty U = k·σ, k = " +
                   coverage_text(k) + " (about 95 % coverage for a normal distribution)";
  return "Decision rule (ILAC-G8:2019, guarded acceptance with the guard band equal to the "
         "expanded uncertainty): " +
         how +
         ". A parameter PASSES when |value| + U is at most the limit, "
         "FAILS when |value| − U exceeds the limit, and is otherwise INDETERMINATE: the limit lies "
         "inside the "
         "uncertainty interval and conformity cannot be stated either way. An indeterminate "
         "parameter, or a limited "
         "parameter this programme could not measure, makes the unit's verdict INDETERMINATE, "
         "which is not a pass. "
         "A limit on σ (1 standard uncertainty) is compared directly. The margin shown is limit − "
         "|value| − U: "
         "positive means room to spare after allowing for the uncertainty.";
}

nlohmann::json conformity_to_json(const ConformityReport& r) {
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  json params = json::object();
  for (const ParameterConformity& c : r.parameters) {
    json e{{"unit", c.unit},
           {"value", opt(c.value)},
           {"sigma", opt(c.sigma)},
           {"expanded_uncertainty", opt(c.expanded_uncertainty)},
           {"max_abs", opt(c.limit.max_abs)},
           {"max_sigma", opt(c.limit.max_sigma)},
           {"value_outcome", outcome_name(c.value_decision.outcome)},
           {"sigma_outcome", outcome_name(c.sigma_outcome)},
           {"outcome", outcome_name(c.outcome)},
           {"explanation", c.explanation}};
    if (c.value && c.limit.max_abs) {
      e["margin"] = c.value_decision.margin;
      e["guarded_margin"] = c.value_decision.guarded_margin;
    }
    params[c.name] = e;
  }
  return {
      {"unit_type", r.unit_type},
      {"limits_source", r.limits_source},
      {"coverage_factor", r.coverage_factor},
      {"rule", decision_rule_text(r.coverage_factor, r.with_budget)},
      {"uncertainty", r.with_budget ? "GUM budget (u_c, U for 95 %)" : "fit sigma, U = k sigma"},
      {"parameters", params},
      {"model_check",
       {{"chi2_dof", opt(r.model_check.chi2_dof)},
        {"max_chi2_dof", opt(r.model_check.max_chi2_dof)},
        {"redundancy", r.model_check.redundancy},
        {"outcome", outcome_name(r.model_check.outcome)},
        {"explanation", r.model_check.explanation}}},
      {"overall", outcome_name(r.overall)},
      {"overall_text", r.overall_text}};
}

}  // namespace standcal::records
