#include "calib/diagnosis/catalog.hpp"

#include <cmath>
#include <stdexcept>

#include "calib/units.hpp"

namespace standcal::diagnosis {

namespace {

using Eigen::MatrixXd;

// A term v on one output (every output term's report unit is micro-something: 1e-6 g).
MatrixXd on_output(const Candidate& c, double v) {
  MatrixXd e = MatrixXd::Zero(3, 1);
  e(c.out_axis, 0) = v * 1e-6;
  return e;
}

double up_i(const Candidate& c, const PositionContext& p) { return p.up[c.out_axis]; }

// Column functions: a term's contribution to J per report unit at a position (model.md's
// parametrisations; time from t = 0, temperature from temp_ref_c).
MatrixXd k2_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, up_i(c, p) * up_i(c, p));
}
MatrixXd k3_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, up_i(c, p) * up_i(c, p) * up_i(c, p));
}
// IEEE 1293's odd-quadratic K_oq a_i |a_i|: the output's scale differs for +a and -a.
MatrixXd odd_quadratic_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, up_i(c, p) * std::abs(up_i(c, p)));
}
MatrixXd drift_g(const Candidate& c, const PositionContext& p) { return on_output(c, p.t_mid_h); }
MatrixXd hysteresis_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, p.approach);
}
MatrixXd bias_temperature_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, p.temp_delta_c);
}
MatrixXd scale_temperature_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, p.temp_delta_c * up_i(c, p));
}
MatrixXd cross_coupling_g(const Candidate& c, const PositionContext& p) {
  return on_output(c, up_i(c, p) * p.up[c.other_axis]);
}
// The true angle is the reading + a sin(alpha) + b cos(alpha) (arcsec), which turns the up
// vector by du/dalpha times that (first order).
MatrixXd cyclic_angle_error_g(const Candidate& c, const PositionContext& p) {
  const bool outer = c.axis == "alpha1";
  const double alpha_rad = (outer ? p.alpha1_deg : p.alpha2_deg) * kDegToRad;
  const Vec3 du = up_derivative(p, outer) * kArcsecToRad;
  MatrixXd e(3, 2);
  e.col(0) = du * std::sin(alpha_rad);
  e.col(1) = du * std::cos(alpha_rad);
  return e;
}

// The stand's base level turns linearly in time about x_S or z_S (arcsec/h from t = 0, as
// bias_drift), which turns the up vector by du/deps times that (first order).
MatrixXd level_drift_g(const Candidate& c, const PositionContext& p) {
  MatrixXd e(3, 1);
  e.col(0) = level_derivative(p, c.out_axis) * (kArcsecToRad * p.t_mid_h);
  return e;
}

std::string accelerometer(const std::string& axis) { return "the " + axis + " accelerometer"; }
std::string first(const std::string& axis) { return axis.substr(0, 1); }
std::string second(const std::string& axis) { return axis.substr(1, 1); }

// typical_max from model.md's typical magnitudes (navigation-grade quartz unit, good
// stand): K2 <= 20 ug/g2 (the other nonlinearities no larger); bias temperature
// coefficient <= 30 ug/degC; a scale temperature coefficient that moves the scale factor
// by its whole range (500 ppm) over a 10 degC swing; bias 20-100 ug (drift: that range
// within an hour; hysteresis and settling: that range); angle error <= 3 arcsec; a level
// that moves by arc-minutes (model.md: "often arc-minutes before" adjustment) within an
// hour; a mounting of a degree or two (model.md's invariant-bias example goes to 2 deg).
// One entry reads as one block of the table:
// clang-format off
const std::vector<CatalogEntry> kCatalog = {
    {.id = "scale_nonlinearity_k2", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/g2", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 20, .excitation = "spread of intermediate angles",
     .effect_g = k2_g,
     .effect_words = [](const std::string& a) {
       return "second-order scale-factor nonlinearity K2 of " + accelerometer(a); },
     .signature_words = [](const std::string& a) {
       return "follow u_" + first(a) + "^2 (u_" + first(a) + "^3 in the projection)"; }},
    {.id = "scale_nonlinearity_k3", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/g3", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 20, .excitation = "spread of intermediate angles",
     .effect_g = k3_g,
     .effect_words = [](const std::string& a) {
       return "third-order scale-factor nonlinearity K3 of " + accelerometer(a); },
     .signature_words = [](const std::string& a) { return "follow u_" + first(a) + "^3"; }},
    {.id = "scale_asymmetry", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/g2", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 20, .excitation = "spread of intermediate angles",
     .effect_g = odd_quadratic_g,
     .effect_words = [](const std::string& a) {
       return "odd-quadratic scale-factor asymmetry K_oq of " + accelerometer(a); },
     .signature_words = [](const std::string& a) {
       return "follow u_" + first(a) + "*|u_" + first(a) + "|"; }},
    {.id = "bias_drift", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/h", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 100, .excitation = "time",
     .effect_g = drift_g,
     .effect_words = [](const std::string& a) { return "bias drift of " + accelerometer(a); },
     .signature_words = [](const std::string&) {
       return std::string("grow with time since the start"); }},
    {.id = "hysteresis", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 100, .excitation = "change of approach direction",
     .effect_g = hysteresis_g,
     .effect_words = [](const std::string& a) {
       return "approach-direction hysteresis of " + accelerometer(a); },
     .signature_words = [](const std::string&) {
       return std::string("change sign with the approach direction"); }},
    {.id = "bias_temperature", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/degC", .needs_temperature = true,
     .invariant_visible = true, .typical_max = 30, .excitation = "temperature change",
     .effect_g = bias_temperature_g,
     .effect_words = [](const std::string& a) {
       return "bias temperature coefficient of " + accelerometer(a); },
     .signature_words = [](const std::string&) { return std::string("follow the temperature"); }},
    {.id = "scale_temperature", .axes = CatalogAxes::output, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ppm/degC", .needs_temperature = true,
     .invariant_visible = true, .typical_max = 50, .excitation = "temperature change",
     .effect_g = scale_temperature_g,
     .effect_words = [](const std::string& a) {
       return "scale-factor temperature coefficient of " + accelerometer(a); },
     .signature_words = [](const std::string& a) {
       return "follow temperature * u_" + first(a); }},
    {.id = "cross_coupling", .axes = CatalogAxes::output_pair, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "ug/g2", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 20, .excitation = "spread of intermediate angles",
     .effect_g = cross_coupling_g,
     .effect_words = [](const std::string& a) {
       return "cross-coupling K_" + a + " (a_" + first(a) + "*a_" + second(a) + " on the " +
              first(a) + " output)"; },
     .signature_words = [](const std::string& a) {
       return "follow u_" + first(a) + "*u_" + second(a); }},
    {.id = "angle_sensor_error", .axes = CatalogAxes::stand_axis, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::cyclic, .unit = "arcsec", .needs_temperature = false,
     .invariant_visible = false,  // it turns u: uT du/dalpha = 0
     .typical_max = 3, .excitation = "spread of the stand angle",
     .effect_g = cyclic_angle_error_g,
     .effect_words = [](const std::string& a) {
       return std::string("cyclic (once per revolution) error of the ") +
              (a == "alpha1" ? "outer" : "inner") + "-axis angle sensor"; },
     .signature_words = [](const std::string& a) {
       return "follow harmonics of " + a + " (turns of the up vector about that axis)"; }},
    {.id = "stand_level_drift", .axes = CatalogAxes::level_axis, .test = CatalogTest::columns,
     .parametrisation = Parametrisation::coefficient, .unit = "arcsec/h",
     .needs_temperature = false, .invariant_visible = false,  // it turns u: uT du/deps = 0
     .typical_max = 60, .excitation = "time", .effect_g = level_drift_g,
     .effect_words = [](const std::string& a) {
       return "drift of the stand's base level about " + a + "_S"; },
     .signature_words = [](const std::string& a) {
       return "show a tilt about " + a + "_S growing with time"; }},
    {.id = "settling_transient", .axes = CatalogAxes::output, .test = CatalogTest::raw_samples,
     .parametrisation = Parametrisation::coefficient, .unit = "ug", .needs_temperature = false,
     .invariant_visible = true, .typical_max = 100, .excitation = "time after arrival",
     .effect_g = nullptr,
     .effect_words = [](const std::string& a) {
       return "settling transient after each move on " + accelerometer(a); },
     .signature_words = [](const std::string&) {
       return std::string("decay inside each dwell after arrival"); }},
    {.id = "mounting_misalignment_large", .axes = CatalogAxes::output,
     .test = CatalogTest::baseline_size,
     .parametrisation = Parametrisation::coefficient, .unit = "arcmin", .needs_temperature = false,
     .invariant_visible = false,  // absorbed into the scale factors and gammas (model.md)
     .typical_max = 120, .excitation = "spread of orientations",
     .effect_g = nullptr,
     .effect_words = [](const std::string& a) {
       return "large mounting misalignment about " + a; },
     .signature_words = [](const std::string&) {
       return std::string("show the mounting in the horizontal components only"); }},
};
// clang-format on

}  // namespace

const std::vector<CatalogEntry>& catalog() { return kCatalog; }

const CatalogEntry* find_catalog_entry(const std::string& id) {
  for (const CatalogEntry& e : kCatalog)
    if (id == e.id) return &e;
  return nullptr;
}

const CatalogEntry& catalog_entry(const std::string& id) {
  if (const CatalogEntry* e = find_catalog_entry(id)) return *e;
  throw std::out_of_range("'" + id + "' is not in the catalog of missing physics");
}

std::vector<Candidate> catalog_candidates(bool have_temperature) {
  auto column_term = [have_temperature](const CatalogEntry& e, CatalogAxes axes) {
    return e.test == CatalogTest::columns && e.axes == axes &&
           (have_temperature || !e.needs_temperature);
  };
  std::vector<Candidate> out;
  for (int i = 0; i < 3; ++i) {
    for (const CatalogEntry& e : kCatalog)
      if (column_term(e, CatalogAxes::output)) out.push_back({&e, kAxisNames[i], i});
    for (const CatalogEntry& e : kCatalog)
      if (column_term(e, CatalogAxes::output_pair))
        for (int j = 0; j < 3; ++j)
          if (j != i) out.push_back({&e, std::string(kAxisNames[i]) + kAxisNames[j], i, j});
  }
  for (const CatalogEntry& e : kCatalog) {
    if (column_term(e, CatalogAxes::stand_axis))
      for (const char* stand_axis : {"alpha1", "alpha2"}) out.push_back({&e, stand_axis});
    if (column_term(e, CatalogAxes::level_axis))
      for (int level_axis : {0, 2}) out.push_back({&e, kAxisNames[level_axis], level_axis});
  }
  return out;
}

Eigen::MatrixXd candidate_effect_g(const Candidate& c, const PositionContext& p) {
  return c.entry->effect_g(c, p);
}

std::string effect_words(const std::string& id, const std::string& axis) {
  const CatalogEntry* e = find_catalog_entry(id);
  return e ? e->effect_words(axis) : id;
}

std::string signature_words(const std::string& id, const std::string& axis) {
  const CatalogEntry* e = find_catalog_entry(id);
  return e ? e->signature_words(axis) : "show structure";
}

}  // namespace standcal::diagnosis
