#include "bench/diagnosis/effect_generator.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"

namespace standcal::bench {

namespace {

const std::vector<std::string> kUnitAxes{"x", "y", "z"};
const std::vector<std::string> kAxisPairs{"xy", "xz", "yx", "yz", "zx", "zy"};
const std::vector<std::string> kStandAxes{"alpha1", "alpha2"};

int unit_axis(char axis) { return static_cast<int>(std::string("xyz").find(axis)); }

// exp(-[theta x]): the frame rotation by the small-angle vector theta (model.md).
Mat3 frame_rotation(const Vec3& theta_rad) {
  const double angle = theta_rad.norm();
  if (angle == 0) return Mat3::Identity();
  return Eigen::AngleAxisd(-angle, theta_rad / angle).toRotationMatrix();
}
// C1: frame rotation by +a about z_S (the outer axis).
Mat3 outer_turn(double a_rad) {
  return Eigen::AngleAxisd(-a_rad, Vec3::UnitZ()).toRotationMatrix();
}
// C2: frame rotation by -a about x (the inner axis): the two angles count in opposite senses.
Mat3 inner_turn(double a_rad) { return Eigen::AngleAxisd(a_rad, Vec3::UnitX()).toRotationMatrix(); }

bool is_effect(const ConcealedEffect& e, const char* id) { return e.id == id; }

// Where the stand is during one dwell, and how it got there.
struct Dwell {
  double alpha1_deg = 0, alpha2_deg = 0;  // commanded = read (the servo holds the reading)
  int approach = +1;
  double t_arrive_s = 0;
};

// model.md's approach rule on the commanded (normalised) angles.
std::vector<int> approach_signs(const Program& program) {
  std::vector<int> signs;
  double from1 = 0, from2 = 0;
  for (const ProgramPosition& p : program.positions) {
    const double d1 = p.alpha1_deg - from1, d2 = p.alpha2_deg - from2;
    const double larger = std::abs(d2) > std::abs(d1) ? d2 : d1;
    signs.push_back(larger < 0 ? -1 : +1);
    from1 = p.alpha1_deg;
    from2 = p.alpha2_deg;
  }
  return signs;
}

void check_effect(const ConcealedEffect& e) {
  const EffectSpec& spec = effect_spec(e.id);
  if (std::find(spec.axes.begin(), spec.axes.end(), e.axis) == spec.axes.end())
    throw std::invalid_argument("generator: " + e.id + " has no axis '" + e.axis + "'");
  if ((e.id == "settling_transient" || e.id == "bias_instability") && !(e.tau_s > 0))
    throw std::invalid_argument("generator: " + e.id + " needs tau_s > 0");
  if (e.id == "bias_oscillation" && !(e.time_s > 0))
    throw std::invalid_argument("generator: bias_oscillation needs its period in time_s > 0");
}

// The unit on the stand, sample by sample (the physics of the comment block in the header).
class UnitOnStand {
 public:
  UnitOnStand(const GeneratorTruth& truth, std::uint64_t seed, double sample_rate_hz)
      : truth_(truth),
        white_sigma_g_(truth.white_noise_ug_rthz * kUg * std::sqrt(sample_rate_hz)),
        rng_(seed) {
    for (const ConcealedEffect& e : truth_.effects)
      if (is_effect(e, "bias_instability"))  // started from its stationary distribution
        coloured_bias_g_[unit_axis(e.axis[0])] += e.value * kUg * gauss_(rng_);
  }

  // Enter a dwell: the stand's rotation from levelled base to instrument axes is fixed.
  void arrive(const Dwell& dwell) {
    dwell_ = dwell;
    base_to_instrument_ =
        frame_rotation(mounting()) * inner_turn(true_angle_rad(2, dwell.alpha2_deg)) *
        frame_rotation(Vec3(0, truth_.stand.skew_y_rad, truth_.stand.skew_z_rad)) *
        outer_turn(true_angle_rad(1, dwell.alpha1_deg));
  }

  Vec3 specific_force_mps2(double t_s) {
    Vec3 J = unit_output_g(true_up(t_s), t_s) + coloured_bias_at_g(t_s);
    for (int i = 0; i < 3; ++i) J[i] += white_sigma_g_ * gauss_(rng_);
    return J * truth_.g_local_mps2;
  }

  double recorded_temperature_c(double t_s) {
    return truth_.chamber.true_c(t_s) + truth_.chamber.sensor_noise_c * gauss_(rng_);
  }

 private:
  Vec3 mounting() const {
    Vec3 psi = truth_.stand.mounting_rad[0];
    for (const ConcealedEffect& e : truth_.effects)
      if (is_effect(e, "mounting_misalignment_large"))
        psi[unit_axis(e.axis[0])] += e.value * kArcminToRad;
    return psi;
  }

  // The true angle of stand axis 1 or 2 when its sensor reads read_deg.
  double true_angle_rad(int stand_axis, double read_deg) const {
    const StandErrors& s = truth_.stand;
    const double read_rad = read_deg * kDegToRad;
    double a = read_rad + (stand_axis == 1 ? s.alpha1_offset_rad + s.alpha1_scale * read_rad
                                           : s.alpha2_offset_rad + s.alpha2_scale * read_rad);
    const std::string name = stand_axis == 1 ? "alpha1" : "alpha2";
    for (const ConcealedEffect& e : truth_.effects) {
      if (e.axis != name) continue;
      const int harmonic = is_effect(e, "angle_sensor_error")       ? 1
                           : is_effect(e, "angle_sensor_harmonic2") ? 2
                                                                    : 0;
      if (harmonic > 0)
        a += e.value * kArcsecToRad * std::sin((harmonic * read_deg + e.phase_deg) * kDegToRad);
    }
    return a;
  }

  // The base's level error at t: fixed levelling plus stand_level_drift from t = 0.
  Vec3 levelling_rad(double t_s) const {
    Vec3 eps(truth_.stand.levelling_x_rad, 0, truth_.stand.levelling_z_rad);
    for (const ConcealedEffect& e : truth_.effects)
      if (is_effect(e, "stand_level_drift"))
        eps[unit_axis(e.axis[0])] += e.value * kArcsecToRad * t_s / 3600.0;
    return eps;
  }

  Vec3 true_up(double t_s) const {
    return base_to_instrument_ * frame_rotation(levelling_rad(t_s)) * Vec3::UnitY();
  }

  // IEEE 1293 form: attitude terms on the input axis's specific force a_i, scaled by 1 + dk_i.
  Vec3 unit_output_g(const Vec3& up, double t_s) const {
    const Vec3 a = (Mat3::Identity() + truth_.unit.gamma_rad) * up;
    const double temp_delta_c = truth_.chamber.true_c(t_s) - truth_.chamber.start_c;
    Vec3 input_terms = a;
    for (const ConcealedEffect& e : truth_.effects) {
      const int i = unit_axis(e.axis[0]);
      const double v = e.value * 1e-6;  // every unit-side report unit is micro-something
      if (is_effect(e, "scale_nonlinearity_k2"))
        input_terms[i] += v * a[i] * a[i];
      else if (is_effect(e, "scale_nonlinearity_k3"))
        input_terms[i] += v * a[i] * a[i] * a[i];
      else if (is_effect(e, "cross_coupling"))
        input_terms[i] += v * a[i] * a[unit_axis(e.axis[1])];
      else if (is_effect(e, "scale_asymmetry"))
        input_terms[i] += v * a[i] * std::abs(a[i]);
      else if (is_effect(e, "scale_temperature"))
        input_terms[i] += v * temp_delta_c * a[i];
    }
    const Vec3 scaled = (Vec3::Ones() + truth_.unit.scale).cwiseProduct(input_terms);
    return truth_.unit.bias_g + attitude_free_bias_g(t_s, temp_delta_c) + scaled;
  }

  // Terms that do not depend on the attitude, catalogued or not.
  Vec3 attitude_free_bias_g(double t_s, double temp_delta_c) const {
    Vec3 b = Vec3::Zero();
    for (const ConcealedEffect& e : truth_.effects) {
      const int i = unit_axis(e.axis[0]);
      const double v = e.value * kUg;
      if (is_effect(e, "bias_temperature"))
        b[i] += v * temp_delta_c;
      else if (is_effect(e, "bias_drift"))
        b[i] += v * t_s / 3600.0;
      else if (is_effect(e, "hysteresis"))
        b[i] += v * dwell_.approach;
      else if (is_effect(e, "settling_transient"))
        b[i] += v * std::exp(-(t_s - dwell_.t_arrive_s) / e.tau_s);
      else if (is_effect(e, "bias_jump"))
        b[i] += t_s >= e.time_s ? v : 0.0;
      else if (is_effect(e, "bias_oscillation"))
        b[i] += v * std::sin(2 * kPi * t_s / e.time_s + e.phase_deg * kDegToRad);
    }
    return b;
  }

  // The Gauss-Markov biases, advanced exactly from the last sample's time to t.
  Vec3 coloured_bias_at_g(double t_s) {
    const double dt = t_s - t_last_s_;
    t_last_s_ = t_s;
    for (const ConcealedEffect& e : truth_.effects) {
      if (!is_effect(e, "bias_instability") || dt <= 0) continue;
      const double decay = std::exp(-dt / e.tau_s);
      double& b = coloured_bias_g_[unit_axis(e.axis[0])];
      b = decay * b + e.value * kUg * std::sqrt(1 - decay * decay) * gauss_(rng_);
    }
    return coloured_bias_g_;
  }

  GeneratorTruth truth_;
  double white_sigma_g_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> gauss_{0.0, 1.0};
  Vec3 coloured_bias_g_ = Vec3::Zero();
  double t_last_s_ = 0;
  Dwell dwell_;
  Mat3 base_to_instrument_ = Mat3::Identity();
};

Recording empty_recording(const GeneratorTruth& truth, const GeneratorRun& run,
                          const Program& program, std::uint64_t seed) {
  Recording rec;
  rec.source = "effect generator";
  rec.set_header("format", std::string(kRecordingFormat));
  rec.set_header("g_local_mps2", round_trip_text(truth.g_local_mps2));
  rec.set_header("settle_s", round_trip_text(run.settle_s));
  rec.set_header("sample_rate_hz", round_trip_text(run.sample_rate_hz));
  rec.set_header("unit_serial", "AU-GEN");
  rec.set_header("program", program.name);
  rec.set_header("generator_seed", std::to_string(seed));
  rec.set_header("temp_ref_c", round_trip_text(truth.chamber.start_c));
  rec.temp_ref_c = truth.chamber.start_c;
  rec.g_local_mps2 = truth.g_local_mps2;
  rec.g_from_header = true;
  rec.settle_s = run.settle_s;
  rec.sample_rate_hz = run.sample_rate_hz;
  rec.unit_serial = "AU-GEN";
  rec.program = program.name;
  rec.columns = {true, true, false, true, true};
  return rec;
}

}  // namespace

const std::vector<EffectSpec>& effect_specs() {
  static const std::vector<EffectSpec> specs{
      {"scale_nonlinearity_k2", "ug/g2", EffectKind::catalog, kUnitAxes, "K2 a_i^2"},
      {"scale_nonlinearity_k3", "ug/g3", EffectKind::catalog, kUnitAxes, "K3 a_i^3"},
      {"cross_coupling", "ug/g2", EffectKind::catalog, kAxisPairs, "K_ij a_i a_j on output i"},
      {"bias_temperature", "ug/degC", EffectKind::catalog, kUnitAxes, "bias x (T - T_start)"},
      {"scale_temperature", "ppm/degC", EffectKind::catalog, kUnitAxes, "(T - T_start) a_i"},
      {"bias_drift", "ug/h", EffectKind::catalog, kUnitAxes, "bias x t / 1 h from t = 0"},
      {"hysteresis", "ug", EffectKind::catalog, kUnitAxes, "h d, d the approach sign"},
      {"settling_transient", "ug", EffectKind::catalog, kUnitAxes, "A exp(-(t - t_arrive) / tau)"},
      {"mounting_misalignment_large", "arcmin", EffectKind::catalog, kUnitAxes,
       "added to the mounting about that instrument axis"},
      {"angle_sensor_error", "arcsec", EffectKind::catalog, kStandAxes,
       "true angle = reading + A sin(alpha + phase)"},
      {"scale_asymmetry", "ug/g2", EffectKind::catalog, kUnitAxes, "K_oq a_i |a_i|"},
      {"stand_level_drift",
       "arcsec/h",
       EffectKind::catalog,
       {"x", "z"},
       "level error about x_S or z_S growing linearly from t = 0"},
      {"bias_instability", "ug", EffectKind::noise, kUnitAxes,
       "Gauss-Markov bias, sigma (value) and tau_s"},
      {"bias_jump", "ug", EffectKind::uncatalogued, kUnitAxes, "bias step at time_s"},
      {"angle_sensor_harmonic2", "arcsec", EffectKind::uncatalogued, kStandAxes,
       "true angle = reading + A sin(2 alpha + phase): twice per revolution"},
      {"bias_oscillation", "ug", EffectKind::uncatalogued, kUnitAxes,
       "bias A sin(2 pi t / period + phase), period time_s, not following temperature"},
  };
  return specs;
}

const EffectSpec& effect_spec(const std::string& id) {
  for (const EffectSpec& s : effect_specs())
    if (s.id == id) return s;
  throw std::invalid_argument("generator: unknown effect '" + id + "'");
}

double ChamberProfile::true_c(double t_s) const {
  return start_c + ramp_c_per_h * t_s / 3600.0 +
         cycle_amplitude_c * std::sin(2 * kPi * t_s / cycle_period_s);
}

GeneratorRun harness_run() {
  GeneratorRun run;
  run.program = diagnostic32();
  return run;
}

GeneratorTruth noise_free(GeneratorTruth truth) {
  truth.white_noise_ug_rthz = 0;
  truth.chamber.sensor_noise_c = 0;
  std::erase_if(truth.effects, [](const ConcealedEffect& e) {
    return effect_spec(e.id).kind == EffectKind::noise;
  });
  return truth;
}

Recording generate_recording(const GeneratorTruth& truth, const GeneratorRun& run,
                             std::uint64_t seed) {
  for (const ConcealedEffect& e : truth.effects) check_effect(e);
  if (!(run.sample_rate_hz > 0 && run.dwell_s > 0 && run.move_rate_deg_s > 0))
    throw std::invalid_argument("generator: sample rate, dwell and move rate must be > 0");
  const Program program = normalise_program(run.program, run.limits);
  for (const ProgramPosition& p : program.positions)
    if (p.mount != Mount::x) throw std::invalid_argument("generator: only mount x is modelled");
  const std::vector<int> approach = approach_signs(program);
  UnitOnStand unit(truth, seed, run.sample_rate_hz);
  Recording rec = empty_recording(truth, run, program, seed);

  double t_s = 0, from1 = 0, from2 = 0;
  for (std::size_t i = 0; i < program.positions.size(); ++i) {
    const ProgramPosition& p = program.positions[i];
    t_s += std::max(std::abs(p.alpha1_deg - from1), std::abs(p.alpha2_deg - from2)) /
           run.move_rate_deg_s;
    const Dwell dwell{p.alpha1_deg, p.alpha2_deg, approach[i], t_s};
    unit.arrive(dwell);
    const double t_first_s = t_s + p.settle_s.value_or(run.settle_s);
    const long n = std::lround(p.dwell_s.value_or(run.dwell_s) * run.sample_rate_hz);
    for (long k = 0; k < n; ++k) {
      RecordingSample s;
      s.t_s = t_first_s + static_cast<double>(k) / run.sample_rate_hz;
      s.pos = static_cast<int>(i);
      s.alpha1_cmd_deg = s.alpha1_deg = p.alpha1_deg;
      s.alpha2_cmd_deg = s.alpha2_deg = p.alpha2_deg;
      s.f_mps2 = unit.specific_force_mps2(s.t_s);
      s.temp_c = unit.recorded_temperature_c(s.t_s);
      s.t_arrive_s = dwell.t_arrive_s;
      s.approach = dwell.approach;
      rec.samples.push_back(s);
      t_s = s.t_s;
    }
    from1 = p.alpha1_deg;
    from2 = p.alpha2_deg;
  }
  return rec;
}

}  // namespace standcal::bench
