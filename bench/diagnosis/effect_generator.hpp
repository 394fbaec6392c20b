#pragma once
// An independent generator of standcal recordings (issue 15): the diagnosis is measured on
// recordings made by code that is NOT the project's simulator. The physics is written
// again from ../shared/docs/model.md, with its own exact rotations (Eigen::AngleAxisd) and
// its own unit model; only the programme (a list of poses), the stand's angle ranges and
// the Recording container are shared with calib.
//
// Conventions (model.md, checked by tests/diagnosis/generator_test.cpp):
// - Frame S: z_S along the horizontal outer axis, y_S up, x_S = y_S x z_S.
// - C1(a) = frame rotation by +a about z_S = AngleAxisd(-a, z);
//   C2(a) = frame rotation by -a about x   = AngleAxisd(+a, x);
//   a small rotation by the vector theta is exp(-[theta x]) = AngleAxisd(-|theta|, theta/|theta|).
// - True up vector (instrument axes, mount x only):
//     u_true = C_psi C2(a2_true) C_n C1(a1_true) C_eps(t) [0, 1, 0]^T
//   with levelling eps = (levelling_x + rate_x t, 0, levelling_z + rate_z t) (stand_level_drift),
//   skew n = (0, skew_y, skew_z), mounting psi = mounting_rad[x], and each axis's true angle
//     a_true = a_read + zero + scale * a_read + sum_k A_k sin(k a_read + phase_k)
//   (k = 1: the catalog's angle_sensor_error, k = 2: the uncatalogued angle_sensor_harmonic2).
//   The servo holds the reading at the commanded angle; the recording's angles are readings.
//   Sign checks: (0, 90 deg) -> z reads +g; (90, 0) -> x reads +g; (45, 90) -> [0.707, 0, 0.707].
// - The unit (IEEE Std 1293 form): a = (I + Gamma) u_true is the specific force along each
//   actual input axis (g); output i is
//     J_i = bias_i + b_i(t) + (1 + dk_i) (a_i + K2 a_i^2 + K3 a_i^3 + K_ij a_i a_j
//                                          + K_oq a_i |a_i| + kT (T - T_start) a_i)
//   where b_i(t) collects the terms that do not depend on attitude: bias temperature
//   coefficient x (T - T_start), drift x t / 1 h from t = 0, hysteresis h x d, settling
//   A exp(-(t - t_arrive) / tau), and the uncatalogued bias jump and bias oscillation.
//   (calib's simulator applies the nonlinear terms to its whole output J instead of a: the
//   two agree exactly when bias, scale and Gamma are zero, and differ by products of two
//   small errors, ~1e-9 g, otherwise.)
// - T is the chamber temperature without its sensor noise; the recording's temp_ref_c is the
//   chamber's start temperature, to which every temperature term is referenced.
// - d (hysteresis, the approach column) follows model.md: the sign of the commanded move into
//   the position on the axis with the larger plain |delta alpha|, ties to alpha1, the first
//   move from (0, 0), no move +1.
// - Timing: the stand starts at (0, 0) at t = 0, moves both axes at once at move_rate_deg_s
//   (the larger move sets the time), arrives, settles, records `dwell_s` at the sample rate;
//   the next move starts at the last sample's time.
// - Noise: white, N ug/rtHz gives one sample a sigma of N sqrt(f_s); the Gauss-Markov bias
//   (bias_instability) is the exact first-order discretisation over each time step, started
//   from its stationary distribution.
#include <cstdint>
#include <string>
#include <vector>

#include "calib/model.hpp"
#include "calib/programs.hpp"
#include "calib/recording.hpp"

namespace standcal::bench {

// What the diagnosis should say about an effect.
enum class EffectKind {
  catalog,       // deterministic, in model.md's catalog: expect it found, with its axis
  noise,         // not white, but no deterministic term: expect `consistent`
  uncatalogued,  // in no catalog: the only right verdict is `unexplained`
};

// One effect concealed in a recording, in its report unit. Axis: "x", "y", "z"; the ordered
// pair "zx" for cross_coupling (output axis first); "alpha1"/"alpha2" for the angle-sensor
// errors; "x"/"z" (the level error's component) for stand_level_drift.
struct ConcealedEffect {
  std::string id;
  std::string axis;
  double value = 0;
  double tau_s = 0;      // settling_transient, bias_instability: time constant (s)
  double phase_deg = 0;  // angle_sensor_error, angle_sensor_harmonic2, bias_oscillation
  double time_s = 0;     // bias_jump: when it jumps; bias_oscillation: its period
};

// The effects the generator can conceal, with what the diagnosis should say about them.
struct EffectSpec {
  std::string id;
  std::string unit;
  EffectKind kind;
  std::vector<std::string> axes;  // every axis the effect can act on
  std::string meaning;
};
const std::vector<EffectSpec>& effect_specs();
// The spec of an id; throws std::invalid_argument for an id the generator does not know.
const EffectSpec& effect_spec(const std::string& id);

// The climatic chamber: a ramp with a cycle on top (the harness's: 10 degC/h, 2 degC / 600 s).
struct ChamberProfile {
  double start_c = 23;
  double ramp_c_per_h = 10;
  double cycle_amplitude_c = 2;
  double cycle_period_s = 600;
  double sensor_noise_c = 0.005;  // of the recorded temperature only

  double true_c(double t_s) const;
};

// Everything about the world the generator needs.
struct GeneratorTruth {
  double g_local_mps2 = 9.81625;
  UnitErrors unit;    // bias, scale, the six gamma_ij (model.md)
  StandErrors stand;  // levelling, angle zeros and scales, skew, mounting (mount x)
  double white_noise_ug_rthz = 10;
  ChamberProfile chamber;
  std::vector<ConcealedEffect> effects;
};

// The run: the harness's programme and timing by default.
struct GeneratorRun {
  Program program;  // mount x only; normalised into `limits` as the stand would
  StandLimits limits;
  double dwell_s = 10;
  double settle_s = 2;
  double sample_rate_hz = 100;
  double move_rate_deg_s = 10;
};
GeneratorRun harness_run();  // diagnostic32(), 10 s dwells, 2 s settle, 100 Hz

// A recording of the run: per sample time, commanded and read angles, approach, arrival,
// temperature and specific force. Seeded and reproducible. Throws std::invalid_argument
// for an unknown effect, an axis an effect does not have, or a position not on mount x.
Recording generate_recording(const GeneratorTruth& truth, const GeneratorRun& run,
                             std::uint64_t seed);

// The same truth without noise (white, coloured, temperature sensor): the deterministic part.
GeneratorTruth noise_free(GeneratorTruth truth);

}  // namespace standcal::bench
