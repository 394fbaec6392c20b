#include "calib/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "calib/atomic_file.hpp"
#include "calib/averaging.hpp"
#include "calib/text.hpp"

namespace standcal {

namespace {

using nlohmann::json;

json vec_json(const Vec3& v, double scale) { return {v.x() * scale, v.y() * scale, v.z() * scale}; }

// The drive of a first-order Gauss-Markov step x <- decay x + drive N(0, 1) that keeps x at
// its stationary sigma (the bias wander, the output filter, the static axes).
double gauss_markov_drive(double stationary_sigma, double decay) {
  return stationary_sigma * std::sqrt(1.0 - decay * decay);
}

// Reads the keys of an object, rejecting unknown ones (a typo in a truth file would
// otherwise silently simulate a perfect unit).
class Keys {
 public:
  Keys(const json& obj, std::string where, std::set<std::string> known)
      : obj_(obj), where_(std::move(where)) {
    if (!obj_.is_object()) throw std::runtime_error(where_ + ": must be a JSON object");
    for (const auto& item : obj_.items())
      if (!known.count(item.key()))
        throw std::runtime_error(where_ + ": unknown key '" + item.key() + "'");
  }
  bool has(const char* key) const { return obj_.contains(key); }
  const json& at(const char* key) const { return obj_.at(key); }
  std::string path(const char* key) const { return where_ + "." + key; }

  void number(const char* key, double& out, double scale = 1.0) const {
    if (!has(key)) return;
    if (!obj_.at(key).is_number()) throw std::runtime_error(path(key) + ": must be a number");
    out = obj_.at(key).get<double>() * scale;
  }
  void vec3(const char* key, Vec3& out, double scale) const {
    if (!has(key)) return;
    const json& a = obj_.at(key);
    if (!a.is_array() || a.size() != 3)
      throw std::runtime_error(path(key) + ": must be an array of 3 numbers [x, y, z]");
    for (std::size_t i = 0; i < 3; ++i) {
      if (!a[i].is_number()) throw std::runtime_error(path(key) + ": must hold numbers");
      out[static_cast<Eigen::Index>(i)] = a[i].get<double>() * scale;
    }
  }

 private:
  const json& obj_;
  std::string where_;
};

void read_gamma(const Keys& unit, UnitErrors& u) {
  if (!unit.has("gamma_arcsec")) return;
  const Keys g(unit.at("gamma_arcsec"), unit.path("gamma_arcsec"),
               {"xy", "yx", "xz", "zx", "yz", "zy"});
  const char* names[3][3] = {{nullptr, "xy", "xz"}, {"yx", nullptr, "yz"}, {"zx", "zy", nullptr}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (names[i][j]) g.number(names[i][j], u.gamma_rad(i, j), kArcsecToRad);
}

void read_stand(const Keys& stand, StandErrors& s) {
  if (stand.has("levelling_arcsec")) {
    const Keys l(stand.at("levelling_arcsec"), stand.path("levelling_arcsec"), {"x", "z"});
    l.number("x", s.levelling_x_rad, kArcsecToRad);
    l.number("z", s.levelling_z_rad, kArcsecToRad);
  }
  if (stand.has("angle_offset_arcsec")) {
    const Keys o(stand.at("angle_offset_arcsec"), stand.path("angle_offset_arcsec"),
                 {"alpha1", "alpha2"});
    o.number("alpha1", s.alpha1_offset_rad, kArcsecToRad);
    o.number("alpha2", s.alpha2_offset_rad, kArcsecToRad);
  }
  if (stand.has("angle_scale_ppm")) {
    const Keys o(stand.at("angle_scale_ppm"), stand.path("angle_scale_ppm"), {"alpha1", "alpha2"});
    o.number("alpha1", s.alpha1_scale, kPpm);
    o.number("alpha2", s.alpha2_scale, kPpm);
  }
  if (stand.has("skew_arcsec")) {
    const Keys k(stand.at("skew_arcsec"), stand.path("skew_arcsec"), {"y", "z"});
    k.number("y", s.skew_y_rad, kArcsecToRad);
    k.number("z", s.skew_z_rad, kArcsecToRad);
  }
  if (stand.has("mounting_arcsec")) {
    const Keys m(stand.at("mounting_arcsec"), stand.path("mounting_arcsec"), {"x", "y", "z"});
    m.vec3("x", s.mounting_rad[0], kArcsecToRad);
    m.vec3("y", s.mounting_rad[1], kArcsecToRad);
    m.vec3("z", s.mounting_rad[2], kArcsecToRad);
  }
}

bool is_pair_axis(const std::string& a) {
  return a.size() == 2 && a[0] != a[1] && std::string("xyz").find(a[0]) != std::string::npos &&
         std::string("xyz").find(a[1]) != std::string::npos;
}

bool is_single_axis(const std::string& a) { return a == "x" || a == "y" || a == "z"; }

ExtraEffect read_extra_effect(const json& item, const std::string& where) {
  const Keys k(item, where, {"id", "axis", "value", "unit", "tau_s", "phase_deg"});
  ExtraEffect e;
  if (!k.has("id") || !k.at("id").is_string())
    throw std::runtime_error(k.path("id") + ": must be a catalog id string");
  e.id = k.at("id").get<std::string>();
  const std::string unit = extra_effect_unit(e.id);
  if (unit.empty())
    throw std::runtime_error(k.path("id") + ": '" + e.id +
                             "' is not an effect the simulator models");
  if (!k.has("axis") || !k.at("axis").is_string())
    throw std::runtime_error(k.path("axis") + ": must be a string");
  e.axis = k.at("axis").get<std::string>();
  const bool pair = e.id == "cross_coupling";
  const bool stand_axis = e.id == "angle_sensor_error";
  if (stand_axis) {
    if (e.axis != "alpha1" && e.axis != "alpha2")
      throw std::runtime_error(k.path("axis") + ": '" + e.axis +
                               "' is not a stand axis, \"alpha1\" or \"alpha2\"");
  } else if (e.id == "stand_level_drift") {
    if (e.axis != "x" && e.axis != "z")
      throw std::runtime_error(k.path("axis") + ": '" + e.axis +
                               "' is not an axis of the stand's levelling error, \"x\" or \"z\"");
  } else if (pair ? !is_pair_axis(e.axis) : !is_single_axis(e.axis)) {
    throw std::runtime_error(k.path("axis") + ": '" + e.axis + "' is not " +
                             (pair ? "an ordered axis pair such as \"zx\"" : "x, y or z"));
  }
  if (!k.has("value")) throw std::runtime_error(k.path("value") + ": missing");
  k.number("value", e.value);
  if (k.has("unit") && (!k.at("unit").is_string() || k.at("unit").get<std::string>() != unit))
    throw std::runtime_error(k.path("unit") + ": must be \"" + unit + "\" for " + e.id);
  k.number("tau_s", e.tau_s);
  if (e.id == "settling_transient" && !(e.tau_s > 0))
    throw std::runtime_error(k.path("tau_s") + ": must be > 0");
  if (k.has("phase_deg") && !stand_axis)
    throw std::runtime_error(k.path("phase_deg") + ": only for angle_sensor_error");
  k.number("phase_deg", e.phase_deg);
  return e;
}

std::vector<ExtraEffect> read_extra_physics(const json& arr, const std::string& where) {
  if (!arr.is_array()) throw std::runtime_error(where + ": must be an array of effects");
  std::vector<ExtraEffect> out;
  for (std::size_t i = 0; i < arr.size(); ++i)
    out.push_back(read_extra_effect(arr[i], where + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace

std::string extra_effect_unit(const std::string& id) {
  if (id == "scale_nonlinearity_k2" || id == "cross_coupling" || id == "scale_asymmetry")
    return "ug/g2";
  if (id == "scale_nonlinearity_k3") return "ug/g3";
  if (id == "bias_temperature") return "ug/degC";
  if (id == "scale_temperature") return "ppm/degC";
  if (id == "bias_drift") return "ug/h";
  if (id == "hysteresis" || id == "settling_transient") return "ug";
  if (id == "angle_sensor_error") return "arcsec";
  if (id == "stand_level_drift") return "arcsec/h";
  return "";
}

int extra_effect_output_axis(const ExtraEffect& e) {
  if (e.id == "angle_sensor_error" || e.id == "stand_level_drift") return -1;
  return static_cast<int>(std::string("xyz").find(e.axis.empty() ? 'x' : e.axis[0]));
}

double angle_sensor_error_deg(const std::vector<ExtraEffect>& extra, int stand_axis,
                              double alpha_deg) {
  const std::string name = stand_axis == 1 ? "alpha1" : "alpha2";
  double error_deg = 0;
  for (const ExtraEffect& e : extra)
    if (e.id == "angle_sensor_error" && e.axis == name)
      error_deg += e.value / 3600.0 * std::sin((alpha_deg + e.phase_deg) * kDegToRad);
  return error_deg;
}

Vec3 level_drift_rad(const std::vector<ExtraEffect>& extra, double t_s) {
  Vec3 level = Vec3::Zero();
  for (const ExtraEffect& e : extra)
    if (e.id == "stand_level_drift")
      level[e.axis == "x" ? 0 : 2] += e.value * kArcsecToRad * t_s / 3600.0;
  return level;
}

double TemperatureProfile::delta_c(double t_s) const {
  double d = rate_c_per_h * t_s / 3600.0;
  if (cycle_amplitude_c != 0 && cycle_period_s > 0)
    d += cycle_amplitude_c * std::sin(2 * kPi * t_s / cycle_period_s);
  return d;
}

double extra_effect_output_g(const ExtraEffect& e, const Vec3& J, double t_s, double temp_delta_c,
                             int approach, double since_arrival_s) {
  const int i = extra_effect_output_axis(e);
  const double v = e.value * 1e-6;  // every catalog unit is micro-something per something
  if (e.id == "scale_nonlinearity_k2") return v * J[i] * J[i];
  if (e.id == "scale_nonlinearity_k3") return v * J[i] * J[i] * J[i];
  if (e.id == "scale_asymmetry") return v * J[i] * std::abs(J[i]);
  if (e.id == "cross_coupling")
    return v * J[i] * J[static_cast<int>(std::string("xyz").find(e.axis[1]))];
  if (e.id == "bias_temperature") return v * temp_delta_c;
  if (e.id == "scale_temperature") return v * temp_delta_c * J[i];
  if (e.id == "bias_drift") return v * t_s / 3600.0;
  if (e.id == "hysteresis") return v * approach;
  if (e.id == "settling_transient")
    return since_arrival_s >= 0 ? v * std::exp(-since_arrival_s / e.tau_s) : 0.0;
  return 0.0;
}

TruthModel default_truth() {
  TruthModel t;
  t.unit.bias_g = Vec3(45, -30, 70) * kUg;
  t.unit.scale = Vec3(150, -220, 310) * kPpm;
  t.unit.gamma_rad << 0, 12, -15, 8, 0, 20, -10, 15, 0;
  t.unit.gamma_rad *= kArcsecToRad;
  t.stand.levelling_x_rad = 1.5 * kArcsecToRad;
  t.stand.levelling_z_rad = -2.0 * kArcsecToRad;
  t.stand.alpha1_offset_rad = 3.0 * kArcsecToRad;
  t.stand.alpha2_offset_rad = -2.0 * kArcsecToRad;
  t.stand.skew_y_rad = 3.0 * kArcsecToRad;
  t.stand.skew_z_rad = -4.0 * kArcsecToRad;
  t.stand.mounting_rad[0] = Vec3(30, -45, 20) * kArcsecToRad;
  t.stand.mounting_rad[1] = Vec3(-25, 40, 15) * kArcsecToRad;
  t.stand.mounting_rad[2] = Vec3(20, 35, -30) * kArcsecToRad;
  return t;
}

namespace {
json base_truth_json(const TruthModel& t) {
  const Mat3& g = t.unit.gamma_rad;
  const double as = kRadToArcsec;
  const StandErrors& s = t.stand;
  return {
      {"format", "standcal-model/1"},
      {"g_local_mps2", t.g_local_mps2},
      {"unit",
       {{"bias_ug", vec_json(t.unit.bias_g, 1.0 / kUg)},
        {"scale_ppm", vec_json(t.unit.scale, 1.0 / kPpm)},
        {"gamma_arcsec",
         {{"xy", g(0, 1) * as},
          {"yx", g(1, 0) * as},
          {"xz", g(0, 2) * as},
          {"zx", g(2, 0) * as},
          {"yz", g(1, 2) * as},
          {"zy", g(2, 1) * as}}}}},
      {"stand",
       {{"levelling_arcsec", {{"x", s.levelling_x_rad * as}, {"z", s.levelling_z_rad * as}}},
        {"angle_offset_arcsec",
         {{"alpha1", s.alpha1_offset_rad * as}, {"alpha2", s.alpha2_offset_rad * as}}},
        {"angle_scale_ppm", {{"alpha1", s.alpha1_scale / kPpm}, {"alpha2", s.alpha2_scale / kPpm}}},
        {"skew_arcsec", {{"y", s.skew_y_rad * as}, {"z", s.skew_z_rad * as}}},
        {"mounting_arcsec",
         {{"x", vec_json(s.mounting_rad[0], as)},
          {"y", vec_json(s.mounting_rad[1], as)},
          {"z", vec_json(s.mounting_rad[2], as)}}}}},
      {"noise",
       {{"density_ug_rthz", t.noise.density_ug_rthz},
        {"bias_instability_ug", t.noise.bias_instability_ug},
        {"bias_instability_tau_s", t.noise.bias_instability_tau_s},
        {"random_walk_ug_rthr", t.noise.random_walk_ug_rthr},
        {"quantization_ug", t.noise.quantization_ug},
        {"angle_noise_arcsec", t.noise.angle_noise_arcsec}}},
      {"temperature",
       {{"start_c", t.temperature.start_c},
        {"rate_c_per_h", t.temperature.rate_c_per_h},
        {"noise_c", t.temperature.noise_c}}}};
}
}  // namespace

json truth_to_json(const TruthModel& t) {
  json doc = base_truth_json(t);
  // Only models with extra physics carry the key, so older model files stay byte-identical.
  if (!t.extra_physics.empty()) {
    json extra = json::array();
    for (const ExtraEffect& e : t.extra_physics) {
      json item = {
          {"id", e.id}, {"axis", e.axis}, {"value", e.value}, {"unit", extra_effect_unit(e.id)}};
      if (e.id == "settling_transient") item["tau_s"] = e.tau_s;
      if (e.id == "angle_sensor_error") item["phase_deg"] = e.phase_deg;
      extra.push_back(item);
    }
    doc["extra_physics"] = extra;
  }
  if (t.noise.output_filter_tau_s > 0)
    doc["noise"]["output_filter_tau_s"] = t.noise.output_filter_tau_s;
  // Likewise the chamber cycle: only profiles that have one carry its keys.
  if (t.temperature.cycle_amplitude_c != 0) {
    doc["temperature"]["cycle_amplitude_c"] = t.temperature.cycle_amplitude_c;
    doc["temperature"]["cycle_period_s"] = t.temperature.cycle_period_s;
  }
  return doc;
}

TruthModel truth_from_json(const json& doc, const std::string& source) {
  const Keys top(
      doc, source,
      {"format", "g_local_mps2", "unit", "stand", "noise", "temperature", "extra_physics"});
  if (top.has("format") && top.at("format") != "standcal-model/1")
    throw std::runtime_error(source + ".format: expected \"standcal-model/1\"");
  TruthModel t;
  t.unit = UnitErrors{};
  t.stand = StandErrors{};
  top.number("g_local_mps2", t.g_local_mps2);
  if (top.has("unit")) {
    const Keys unit(top.at("unit"), top.path("unit"), {"bias_ug", "scale_ppm", "gamma_arcsec"});
    unit.vec3("bias_ug", t.unit.bias_g, kUg);
    unit.vec3("scale_ppm", t.unit.scale, kPpm);
    read_gamma(unit, t.unit);
  }
  if (top.has("stand"))
    read_stand(Keys(top.at("stand"), top.path("stand"),
                    {"levelling_arcsec", "angle_offset_arcsec", "angle_scale_ppm", "skew_arcsec",
                     "mounting_arcsec"}),
               t.stand);
  if (top.has("noise")) {
    const Keys n(
        top.at("noise"), top.path("noise"),
        {"density_ug_rthz", "bias_instability_ug", "bias_instability_tau_s", "random_walk_ug_rthr",
         "quantization_ug", "angle_noise_arcsec", "output_filter_tau_s"});
    n.number("density_ug_rthz", t.noise.density_ug_rthz);
    n.number("bias_instability_ug", t.noise.bias_instability_ug);
    n.number("bias_instability_tau_s", t.noise.bias_instability_tau_s);
    n.number("random_walk_ug_rthr", t.noise.random_walk_ug_rthr);
    n.number("quantization_ug", t.noise.quantization_ug);
    n.number("angle_noise_arcsec", t.noise.angle_noise_arcsec);
    n.number("output_filter_tau_s", t.noise.output_filter_tau_s);
    if (t.noise.output_filter_tau_s < 0)
      throw std::runtime_error(n.path("output_filter_tau_s") + ": must be >= 0");
    if (t.noise.bias_instability_tau_s <= 0)
      throw std::runtime_error(n.path("bias_instability_tau_s") + ": must be > 0");
  }
  if (top.has("temperature")) {
    const Keys k(top.at("temperature"), top.path("temperature"),
                 {"start_c", "rate_c_per_h", "noise_c", "cycle_amplitude_c", "cycle_period_s"});
    k.number("start_c", t.temperature.start_c);
    k.number("rate_c_per_h", t.temperature.rate_c_per_h);
    k.number("noise_c", t.temperature.noise_c);
    k.number("cycle_amplitude_c", t.temperature.cycle_amplitude_c);
    k.number("cycle_period_s", t.temperature.cycle_period_s);
    if (!(t.temperature.cycle_period_s > 0))
      throw std::runtime_error(k.path("cycle_period_s") + ": must be > 0");
  }
  if (top.has("extra_physics"))
    t.extra_physics = read_extra_physics(top.at("extra_physics"), top.path("extra_physics"));
  return t;
}

TruthModel load_truth(const std::string& path) {
  std::error_code ec;  // a directory reads as "basic_filebuf::underflow", naming nothing
  if (std::filesystem::is_directory(path, ec))
    throw std::runtime_error(path + ": is a directory, not a model file");
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open model file");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    throw std::runtime_error(path + ": not valid JSON (" + e.what() + ")");
  }
  return truth_from_json(doc, path);
}

void save_truth(const TruthModel& truth, const std::string& path) {
  write_file_atomically(path, truth_to_json(truth).dump(2) + "\n", "the model file");
}

UnitSimulator::UnitSimulator(const TruthModel& truth, std::uint64_t seed, double sample_rate_hz)
    : truth_(truth),
      sample_sigma_g_(truth.noise.density_ug_rthz * kUg * std::sqrt(sample_rate_hz)),
      rng_(seed) {
  for (const ExtraEffect& e : truth_.extra_physics)
    level_drifts_ = level_drifts_ || e.id == "stand_level_drift";
  for (int a = 0; a < 3; ++a)
    bias_gauss_markov_g_[a] = truth_.noise.bias_instability_ug * kUg * gauss_(rng_);
  if (truth_.noise.output_filter_tau_s > 0) {
    // The low-pass y_k = a y_(k-1) + (1 - a) x_k of the per-sample white noise x (a = e^(-tau0
    // / tau_f)) is stationary at sigma^2 (1 - a) / (1 + a); it starts there.
    const double a = std::exp(-1 / (sample_rate_hz * truth_.noise.output_filter_tau_s));
    filtered_sigma_g_ = sample_sigma_g_ * std::sqrt((1 - a) / (1 + a));
    for (int k = 0; k < 3; ++k) filtered_noise_g_[k] = filtered_sigma_g_ * gauss_(rng_);
  }
}

void UnitSimulator::advance_bias_processes(double t_s) {
  const double dt = t_s - t_last_s_;
  if (dt <= 0) return;
  t_last_s_ = t_s;
  const NoiseModel& n = truth_.noise;
  if (n.bias_instability_ug > 0) {
    const double decay = std::exp(-dt / n.bias_instability_tau_s);
    const double drive = gauss_markov_drive(n.bias_instability_ug * kUg, decay);
    for (int a = 0; a < 3; ++a)
      bias_gauss_markov_g_[a] = decay * bias_gauss_markov_g_[a] + drive * gauss_(rng_);
  }
  if (n.random_walk_ug_rthr > 0) {
    const double step = n.random_walk_ug_rthr * kUg * std::sqrt(dt / 3600.0);
    for (int a = 0; a < 3; ++a) bias_random_walk_g_[a] += step * gauss_(rng_);
  }
}

Vec3 UnitSimulator::specific_force_mps2(double t_s, double alpha1_cmd_deg, double alpha2_cmd_deg,
                                        Mount m) {
  advance_bias_processes(t_s);
  // The stand holds still during a dwell: compute the noise-free output once per position,
  // unless its base level drifts.
  if (!cached_ || level_drifts_ || alpha1_cmd_deg != cached_alpha1_deg_ ||
      alpha2_cmd_deg != cached_alpha2_deg_ || m != cached_mount_) {
    // A cyclic angle-sensor error moves the true angle away from the one the servo holds.
    const double a1_deg =
        alpha1_cmd_deg + angle_sensor_error_deg(truth_.extra_physics, 1, alpha1_cmd_deg);
    const double a2_deg =
        alpha2_cmd_deg + angle_sensor_error_deg(truth_.extra_physics, 2, alpha2_cmd_deg);
    StandErrors stand = truth_.stand;
    const Vec3 level_drift = level_drift_rad(truth_.extra_physics, t_s);
    stand.levelling_x_rad += level_drift.x();
    stand.levelling_z_rad += level_drift.z();
    const Vec3 u_true = true_up_vector(a1_deg * kDegToRad, a2_deg * kDegToRad, m, stand);
    cached_J_g_ = unit_output_g(truth_.unit, u_true);
    cached_alpha1_deg_ = alpha1_cmd_deg;
    cached_alpha2_deg_ = alpha2_cmd_deg;
    cached_mount_ = m;
    cached_ = true;
  }
  Vec3 J = cached_J_g_ + bias_gauss_markov_g_ + bias_random_walk_g_;
  if (!truth_.extra_physics.empty()) {
    // Deterministic terms only: the noise sequence stays that of the same model without them.
    const double temp_delta_c = truth_.temperature.delta_c(t_s);  // noise-free T - start_c
    for (const ExtraEffect& e : truth_.extra_physics) {
      const int axis = extra_effect_output_axis(e);
      if (axis >= 0)
        J[axis] +=
            extra_effect_output_g(e, cached_J_g_, t_s, temp_delta_c, approach_, t_s - t_arrive_s_);
    }
  }
  if (filtered_sigma_g_ > 0) {
    // The filter's state decays over the time since the last sample, moves and pauses
    // included (for samples one period apart: the low-pass above, step for step).
    const double decay = std::exp(-(t_s - t_filtered_s_) / truth_.noise.output_filter_tau_s);
    const double drive = gauss_markov_drive(filtered_sigma_g_, decay);
    t_filtered_s_ = t_s;
    for (int a = 0; a < 3; ++a) {
      filtered_noise_g_[a] = decay * filtered_noise_g_[a] + drive * gauss_(rng_);
      J[a] += filtered_noise_g_[a];
    }
  } else {
    for (int a = 0; a < 3; ++a) J[a] += sample_sigma_g_ * gauss_(rng_);
  }
  Vec3 f = J * truth_.g_local_mps2;
  if (truth_.noise.quantization_ug > 0) {
    const double lsb_mps2 = truth_.noise.quantization_ug * kUg * truth_.g_local_mps2;
    for (int a = 0; a < 3; ++a) f[a] = lsb_mps2 * std::round(f[a] / lsb_mps2);
  }
  return f;
}

void UnitSimulator::set_position_context(int approach, double t_arrive_s) {
  approach_ = approach;
  t_arrive_s_ = t_arrive_s;
}

double UnitSimulator::temperature_c(double t_s) {
  const TemperatureProfile& p = truth_.temperature;
  return p.start_c + p.delta_c(t_s) + p.noise_c * gauss_(rng_);
}

double UnitSimulator::angle_reading_deg(double alpha_cmd_deg) {
  return alpha_cmd_deg + truth_.noise.angle_noise_arcsec / 3600.0 * gauss_(rng_);
}

Recording simulate_run(const SimulationRequest& req) {
  const Program program = normalise_program(req.program, req.limits);
  if (req.timing.sample_rate_hz <= 0 || req.timing.dwell_s <= 0 || req.timing.move_rate_deg_s <= 0)
    throw std::runtime_error("simulation needs sample rate, dwell and move rate > 0");
  UnitSimulator unit(req.truth, req.seed, req.timing.sample_rate_hz);
  Recording rec;
  rec.source = "simulation";
  rec.set_header("format", std::string(kRecordingFormat));
  rec.set_header("g_local_mps2", round_trip_text(req.truth.g_local_mps2));
  rec.set_header("settle_s", round_trip_text(req.timing.settle_s));
  rec.set_header("sample_rate_hz", round_trip_text(req.timing.sample_rate_hz));
  rec.set_header("unit_serial", req.unit_serial);
  rec.set_header("program", program.name);
  rec.set_header("simulation_seed", std::to_string(req.seed));
  if (!req.truth.extra_physics.empty()) {
    // Temperature terms of the extra physics are referenced to the profile's start.
    if (!is_plausible_temperature(req.truth.temperature.start_c))
      throw std::runtime_error("the model's temperature.start_c (the recording's temp_ref_c): " +
                               implausible_temperature_text(req.truth.temperature.start_c));
    rec.set_header("temp_ref_c", round_trip_text(req.truth.temperature.start_c));
    rec.temp_ref_c = req.truth.temperature.start_c;
  }
  rec.g_local_mps2 = req.truth.g_local_mps2;
  rec.g_from_header = true;
  rec.settle_s = req.timing.settle_s;
  rec.sample_rate_hz = req.timing.sample_rate_hz;
  rec.unit_serial = req.unit_serial;
  rec.program = program.name;
  if (program.warmup_s > 0) {
    rec.set_header(kHeaderWarmupS, round_trip_text(program.warmup_s));
    rec.warmup_s = program.warmup_s;
  }
  rec.columns = {true, true, !program.remount_before().empty(), true, true};

  std::vector<std::pair<double, double>> commanded;
  for (const auto& p : program.positions) commanded.emplace_back(p.alpha1_deg, p.alpha2_deg);
  const std::vector<int> approach = approach_directions(commanded);
  const std::vector<std::size_t> remounts = program.remount_before();

  double t_s = 0, a1 = 0, a2 = 0;
  for (std::size_t i = 0; i < program.positions.size(); ++i) {
    const ProgramPosition& p = program.positions[i];
    if (std::find(remounts.begin(), remounts.end(), i) != remounts.end())
      t_s += req.timing.remount_s;
    t_s += std::max(std::abs(p.alpha1_deg - a1), std::abs(p.alpha2_deg - a2)) /
           req.timing.move_rate_deg_s;
    const double t_arrive_s = t_s;
    const double t_first_s = t_arrive_s + p.settle_s.value_or(req.timing.settle_s);
    unit.set_position_context(approach[i], t_arrive_s);
    // The first position's warm-up is recorded ahead of its dwell, in the same block.
    const double held_s = p.dwell_s.value_or(req.timing.dwell_s) + (i == 0 ? program.warmup_s : 0);
    const auto n = static_cast<long>(std::llround(held_s * req.timing.sample_rate_hz));
    for (long k = 0; k < n; ++k) {
      RecordingSample s;
      s.t_s = t_first_s + static_cast<double>(k) / req.timing.sample_rate_hz;
      s.pos = static_cast<int>(i);
      s.alpha1_cmd_deg = p.alpha1_deg;
      s.alpha2_cmd_deg = p.alpha2_deg;
      s.alpha1_deg = unit.angle_reading_deg(p.alpha1_deg);
      s.alpha2_deg = unit.angle_reading_deg(p.alpha2_deg);
      s.f_mps2 = unit.specific_force_mps2(s.t_s, p.alpha1_deg, p.alpha2_deg, p.mount);
      s.temp_c = unit.temperature_c(s.t_s);
      if (rec.columns.mount) s.mount = p.mount;
      s.t_arrive_s = t_arrive_s;
      s.approach = static_cast<std::int8_t>(approach[i]);
      if (const std::string wrong = implausible_sample_text(s); !wrong.empty())
        throw std::runtime_error("simulating position " + std::to_string(i + 1) +
                                 ": the model gives a sample no recording holds: " + wrong);
      rec.samples.push_back(s);
      t_s = s.t_s;
    }
    a1 = p.alpha1_deg;
    a2 = p.alpha2_deg;
  }
  return rec;
}

std::vector<std::vector<double>> simulate_static_gauss_markov(double white_density, double q,
                                                              double tau_c_s, double seconds,
                                                              double rate_hz, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  const auto samples = static_cast<std::size_t>(seconds * rate_hz);
  const double phi = std::exp(-1 / (rate_hz * tau_c_s));
  const double drive = gauss_markov_drive(q, phi);
  std::vector<std::vector<double>> axes;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> y(samples);
    double wander = q * gauss(rng);
    for (double& v : y) {
      wander = phi * wander + drive * gauss(rng);
      v = wander + white_density * std::sqrt(rate_hz) * gauss(rng);
    }
    axes.push_back(std::move(y));
  }
  return axes;
}

}  // namespace standcal
