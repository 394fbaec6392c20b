#pragma once
// The simulated calibration run: per-sample streams from the full measurement model
// (model.md) with white noise, bias instability, bias random walk, quantisation, a
// temperature profile, stand moves, settling and dwell. Seeded and reproducible.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <random>
#include <string>
#include <vector>

#include "calib/model.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"

namespace standcal {

struct NoiseModel {
  double density_ug_rthz = 10;     // white noise N; one sample has sigma N*sqrt(fs)
  double bias_instability_ug = 0;  // first-order Gauss-Markov bias, steady-state sigma
  double bias_instability_tau_s = 300;
  double random_walk_ug_rthr = 0;  // bias random walk: sigma grows as K*sqrt(t / 1 h)
  double quantization_ug = 0;      // output LSB, 0 = none
  double angle_noise_arcsec = 0;   // noise of the recorded angle-sensor readings
  // The unit's output filter: the white noise through a first-order low-pass of this time
  // constant, unit gain at zero frequency (so a long mean's error is still N / sqrt(T), while
  // the samples scatter less and are correlated); 0 = none (independent samples).
  double output_filter_tau_s = 0;
};

struct TemperatureProfile {
  double start_c = 23;
  double rate_c_per_h = 0;
  double noise_c = 0.005;
  // A climatic chamber cycling on top of the ramp: + amplitude * sin(2 pi t / period).
  // Zero amplitude (the default) keeps the profile a straight line in time.
  double cycle_amplitude_c = 0;
  double cycle_period_s = 3600;

  // Noise-free temperature minus start_c at time t_s.
  double delta_c(double t_s) const;
};

// One effect of the catalog of physics the calibration model leaves out (model.md,
// "Physics the model leaves out"), in its report unit. `axis` is "x", "y" or "z", or for
// cross_coupling the output axis then the other axis ("zx": K_zx a_z a_x on the z output),
// for angle_sensor_error the stand axis "alpha1" or "alpha2", for stand_level_drift the axis
// of the levelling error "x" (x_S) or "z" (z_S).
// Temperature terms are referenced to the temperature profile's start_c (the simulator
// then writes `temp_ref_c` into the recording), drift to t = 0, hysteresis is h * d.
// angle_sensor_error is the once-per-revolution cyclic error of a stand axis's angle
// sensor (encoder eccentricity): the true angle is the reading + value * sin(alpha + phase).
// scale_asymmetry is IEEE 1293's odd-quadratic K_oq a_i |a_i|; stand_level_drift turns the
// stand's levelling error (model.md's C_eps) by value * t from t = 0.
struct ExtraEffect {
  std::string id;  // bias_temperature, bias_drift, hysteresis, settling_transient,
                   // scale_nonlinearity_k2, scale_nonlinearity_k3, cross_coupling,
                   // scale_temperature, angle_sensor_error, scale_asymmetry,
                   // stand_level_drift
  std::string axis;
  double value = 0;  // ug/g2, ug/g3, ug/g2, ug/degC, ppm/degC, ug/h, ug, ug (amplitude), arcsec,
                     // ug/g2, arcsec/h
  double tau_s = 0;  // settling_transient only: time constant after arrival
  double phase_deg = 0;  // angle_sensor_error only
};

// The report unit of a catalog id ("" when the id is unknown to the simulator).
std::string extra_effect_unit(const std::string& id);
// The effect's contribution to J (in g) of one accelerometer output. J_nominal is the
// noise-free output without extra physics; temp_delta_c = T - temp_ref; approach = +-1.
double extra_effect_output_g(const ExtraEffect& e, const Vec3& J_nominal_g, double t_s,
                             double temp_delta_c, int approach, double time_since_arrival_s);
// Index 0..2 of the output axis an effect acts on; -1 for an effect of the stand
// (angle_sensor_error, stand_level_drift), which acts through the geometry instead.
int extra_effect_output_axis(const ExtraEffect& e);
// The true-minus-read angle (deg) of stand axis 1 or 2 at reading alpha_deg from the
// angle_sensor_error effects among `extra` (0 when there are none).
double angle_sensor_error_deg(const std::vector<ExtraEffect>& extra, int stand_axis,
                              double alpha_deg);
// The levelling error (rad, about x_S and z_S; y is 0) the stand_level_drift effects among
// `extra` have added by time t_s.
Vec3 level_drift_rad(const std::vector<ExtraEffect>& extra, double t_s);

// Everything the simulator needs to know about the world: the `--truth` / `--model`
// JSON (format standcal-model/1).
struct TruthModel {
  double g_local_mps2 = 9.81625;
  UnitErrors unit;
  StandErrors stand;
  NoiseModel noise;
  TemperatureProfile temperature;
  std::vector<ExtraEffect> extra_physics;  // optional `extra_physics` array in the JSON
};

// A realistic navigation-grade unit on a well-adjusted stand (model.md magnitudes).
TruthModel default_truth();
nlohmann::json truth_to_json(const TruthModel& truth);
// Reads a model; throws std::runtime_error naming `source` and the bad key.
TruthModel truth_from_json(const nlohmann::json& doc, const std::string& source);
TruthModel load_truth(const std::string& path);
void save_truth(const TruthModel& truth, const std::string& path);

struct RunTiming {
  double sample_rate_hz = 100;
  double dwell_s = 60;
  double settle_s = 5;
  double move_rate_deg_s = 10;
  double remount_s = 600;
};

// The unit on the stand, sample by sample. Noise processes advance with time, so the
// calls must come in non-decreasing t_s (the drivers' simulated backend uses this too).
class UnitSimulator {
 public:
  UnitSimulator(const TruthModel& truth, std::uint64_t seed, double sample_rate_hz);
  // Specific force (m/s^2) at time t_s with the stand at the commanded angles.
  Vec3 specific_force_mps2(double t_s, double alpha1_cmd_deg, double alpha2_cmd_deg, Mount m);
  // Unit temperature at time t_s (deg C).
  double temperature_c(double t_s);
  // A recorded angle-sensor reading of a commanded angle (with the sensor noise).
  double angle_reading_deg(double alpha_cmd_deg);
  // Where the stand came from into the current position (approach +-1, model.md rule)
  // and when it arrived: hysteresis and settling transients of the extra physics need
  // them. Without a call: approach +1 and no transient.
  void set_position_context(int approach, double t_arrive_s);

 private:
  void advance_bias_processes(double t_s);

  TruthModel truth_;
  double sample_sigma_g_;
  double filtered_sigma_g_ = 0;  // the output filter's stationary sigma, 0 without a filter
  double t_filtered_s_ = 0;      // the time of the filter's state
  std::mt19937_64 rng_;
  std::normal_distribution<double> gauss_{0.0, 1.0};
  double t_last_s_ = 0;
  Vec3 bias_gauss_markov_g_ = Vec3::Zero();
  Vec3 bias_random_walk_g_ = Vec3::Zero();
  Vec3 filtered_noise_g_ = Vec3::Zero();  // the output filter's state
  bool cached_ = false;                   // noise-free output of the last stand position
  double cached_alpha1_deg_ = 0;
  double cached_alpha2_deg_ = 0;
  Mount cached_mount_ = Mount::x;
  Vec3 cached_J_g_ = Vec3::Zero();
  bool level_drifts_ = false;  // stand_level_drift: the geometry changes sample by sample
  int approach_ = +1;
  double t_arrive_s_ = -1e300;
};

struct SimulationRequest {
  Program program;
  TruthModel truth;
  RunTiming timing;
  StandLimits limits;
  std::uint64_t seed = 1;
  std::string unit_serial = "AU-SIM";
};

// A whole run in the recording format: the stand starts at (0, 0) at t = 0, moves to
// each position at the move rate (both axes at once), settles, then records the dwell.
Recording simulate_run(const SimulationRequest& request);

// A static unit's three axes alone, without the stand or the recording format: per axis,
// white noise of density white_density (per sqrt(Hz)) and a first-order Gauss-Markov wander
// (stationary sigma q, correlation time tau_c_s), sampled at rate_hz for `seconds`, in the
// units of white_density and q. Quick to draw hours of: what the Allan fit of the
// correlation time is tested and benchmarked on (standcal-bench-allan-tau).
std::vector<std::vector<double>> simulate_static_gauss_markov(double white_density, double q,
                                                              double tau_c_s, double seconds,
                                                              double rate_hz, unsigned seed);

}  // namespace standcal
