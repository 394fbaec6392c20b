#include "calib/diagnosis/json.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "calib/allan.hpp"
#include "calib/averaging.hpp"
#include "calib/diagnosis/catalog.hpp"
#include "calib/report.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace diagnosis {

namespace {

// The recording's rate: its header, else its time steps (a recording without the header was
// taken as 100 Hz); 100 Hz only where it has neither.
double sample_rate_or_assumed_hz(const Recording& rec) {
  try {
    return 1 / sample_period_s(rec);
  } catch (const std::exception&) {
    return 100.0;
  }
}

// A white-noise density (ug/rtHz) from the median dwell sigma, widened where the samples
// are correlated among themselves (a unit's output filter, calib/averaging.hpp): the density
// a dwell mean sees, which the simulator's white noise is (its own filter is not carried).
double noise_density_ug_rthz(const Recording& rec, const std::vector<PositionAverage>& avg) {
  std::vector<double> sig;
  for (const auto& p : avg) {
    double sum = 0;
    for (int a = 0; a < 3; ++a) sum += p.sigma_g[a] * correlation_widening(p, a);
    sig.push_back(sum / 3);
  }
  std::nth_element(sig.begin(), sig.begin() + static_cast<std::ptrdiff_t>(sig.size() / 2),
                   sig.end());
  return sig[sig.size() / 2] / kUg / std::sqrt(sample_rate_or_assumed_hz(rec));
}

}  // namespace

TruthModel augmented_model(const Diagnosis& d, const Recording& rec, const Prepared& P,
                           const MountingEstimate* large_mounting) {
  TruthModel m;
  m.g_local_mps2 = rec.g_local_mps2;
  Vec3 pair_sums = Vec3::Zero();
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const double v = d.final_fit.unit[static_cast<std::size_t>(i)].value.value_or(0.0);
    if (i < 3)
      m.unit.bias_g[i] = v;
    else if (i < 6)
      m.unit.scale[i - 3] = v;
    else
      pair_sums[i - 6] = v;
  }
  m.unit.set_gamma_pair_sums_rad(pair_sums);
  if (large_mounting)  // the one stand error that matters beyond first order
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(large_mounting->value_arcmin[a]))
        m.stand.mounting_rad[static_cast<std::size_t>(P.avg.front().mount)][a] =
            large_mounting->value_arcmin[a] * kArcminToRad;
  m.noise.density_ug_rthz = noise_density_ug_rthz(rec, P.avg);
  m.temperature.start_c = P.temp_ref_c;
  m.temperature.noise_c = 0;
  if (P.have_temp && P.avg.size() > 1) {
    const double dt_h = P.ctx.back().t_mid_h - P.ctx.front().t_mid_h;
    if (dt_h > 0)
      m.temperature.rate_c_per_h = (P.ctx.back().temp_delta_c - P.ctx.front().temp_delta_c) / dt_h;
  }
  for (const Finding& f : d.findings)  // a large mounting is in the stand errors instead
    if (catalog_entry(f.effect).test != CatalogTest::baseline_size)
      m.extra_physics.push_back({f.effect, f.axis, f.value, f.tau_s, f.phase_deg});
  return m;
}

namespace {

nlohmann::json checks_json(const HonestyChecks& c) {
  using nlohmann::json;
  if (!c.made) return nullptr;
  json whiteness = json::array();
  for (const WhitenessCheck& w : c.whiteness)
    whiteness.push_back({{"axis", w.axis},
                         {"against", w.against},
                         {"test", w.test},
                         {"statistic", w.statistic},
                         {"p_value", w.p},
                         {"positions", w.positions},
                         {"t_from_s", w.t_from_s},
                         {"t_to_s", w.t_to_s}});
  auto finite = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json stability = json::array();
  for (const StabilityCheck& k : c.stability)
    stability.push_back({{"effect", k.effect},
                         {"axis", k.axis},
                         {"unit", k.unit},
                         {"value", finite(k.value)},
                         {"sigma", finite(k.sigma)},
                         {"halves", k.halves},
                         {"first_half", finite(k.first)},
                         {"first_half_sigma", finite(k.first_sigma)},
                         {"second_half", finite(k.second)},
                         {"second_half_sigma", finite(k.second_sigma)},
                         {"z", k.z},
                         {"stable", k.stable}});
  return {{"passed", c.passed},
          {"family_alpha", c.family_alpha},
          {"whiteness", whiteness},
          {"worst", c.worst},
          {"stability", stability},
          {"implausible", c.implausible},
          {"not_explaining", c.not_explaining}};
}

}  // namespace

}  // namespace diagnosis

nlohmann::json diagnose_to_json(const Diagnosis& d) {
  using diagnosis::find_catalog_entry;
  using nlohmann::json;
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  auto cyclic = [](const std::string& id) {  // reported as amplitude and phase
    const diagnosis::CatalogEntry* e = find_catalog_entry(id);
    return e && e->parametrisation == diagnosis::Parametrisation::cyclic;
  };
  auto timed = [](const std::string& id) {  // a time constant besides its value
    const diagnosis::CatalogEntry* e = find_catalog_entry(id);
    return e && e->test == diagnosis::CatalogTest::raw_samples;
  };
  json findings = json::array();
  for (const Finding& f : d.findings) {
    json j = {{"effect", f.effect},
              {"axis", f.axis},
              {"value", f.value},
              {"sigma", f.sigma},
              {"unit", f.unit},
              {"chi2_dof_after", number(f.chi2_dof_after)},
              {"delta_chi2", f.delta_chi2},
              {"explanation", f.explanation}};
    if (timed(f.effect)) j["tau_s"] = f.tau_s;
    if (cyclic(f.effect)) j["phase_deg"] = f.phase_deg;
    if (!f.absorbed_into.empty()) j["absorbed_into"] = f.absorbed_into;
    findings.push_back(j);
  }
  json candidates = json::array();
  for (const CandidateTest& c : d.candidates) {
    json j = {{"effect", c.effect}, {"axis", c.axis}, {"unit", c.unit}, {"testable", c.testable}};
    if (c.testable) {
      j["value"] = c.value;
      j["sigma"] = c.sigma;
      j["delta_chi2"] = c.delta_chi2;
      j["delta_bic"] = c.delta_bic;
      j["heldout_gain"] =
          number(c.press_gain);  // null where it does not apply (mounting size test)
      if (c.params > 1) j["params"] = c.params;
      if (cyclic(c.effect)) j["phase_deg"] = c.phase_deg;
    } else {
      j["reason"] = c.reason;
    }
    candidates.push_back(j);
  }
  json structure = json::array();
  for (const StructureTest& s : d.structure)
    structure.push_back({{"axis", s.axis}, {"against", s.against}, {"z", s.z}});
  json proposed = json::array();
  for (const ProposedPosition& p : d.proposed_positions) {
    json j = {{"alpha1_deg", p.alpha1_deg}, {"alpha2_deg", p.alpha2_deg}, {"why", p.why}};
    if (p.predicted_difference_sigma > 0)
      j["predicted_difference_sigma"] = p.predicted_difference_sigma;
    proposed.push_back(j);
  }
  return {{"verdict", d.verdict},
          {"method", d.method},
          {"baseline",
           {{"chi2_dof", number(d.baseline.chi2_dof)},
            {"p_value", d.baseline_p},
            {"residual_rms_ug", d.baseline.residual_rms_g / kUg}}},
          {"findings", findings},
          {"final",
           {{"chi2_dof", number(d.final_chi2_dof)},
            {"p_value", d.final_p},
            {"residual_rms_ug", d.final_fit.residual_rms_g / kUg},
            {"parameters", fit_to_json(d.final_fit)}}},
          {"proposed_positions", proposed},
          {"structure_tests", structure},
          {"located", d.located},
          {"candidates", candidates},
          {"not_tested", d.not_tested},
          {"noise", noise_finding_json(d.noise)},
          {"checks", diagnosis::checks_json(d.checks)},
          {"summary", d.summary},
          {"model", truth_to_json(d.model)}};
}

}  // namespace standcal
