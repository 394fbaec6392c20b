#pragma once
// The attitude-free estimator: with no stand angle, the only thing a static interval says
// is that the calibrated specific force has gravity's magnitude,
//   |M (raw - b)| = g,   M = T K,
// T unit upper-triangular (the axes' non-orthogonality, imu_tk's convention), K diagonal
// (inverse scale factors), b the bias, all in the input's units (docs/calibration.md,
// "Recordings without angles"). A rotation of M leaves every |.| unchanged, so T's
// triangular form is the choice that removes it.
//
// The start is closed form (an ellipsoid through the interval means), then Gauss-Newton
// with Levenberg-Marquardt damping. The sigmas, chi-square and noise model come from the
// invariant estimator run on the calibrated interval means: linearised at the solution,
// |f| = g IS the paper's invariant measurement with u the measured direction, so one noise
// treatment (GLS under bias wander, Student-t for an estimated noise) serves both.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/noise_model.hpp"
#include "calib/raw_input.hpp"
#include "calib/static_intervals.hpp"

namespace standcal {

// f = M (raw - b): raw in input units, f in m/s^2.
struct NormCompensation {
  Vec3 bias = Vec3::Zero();          // b, input units
  Mat3 matrix = Mat3::Identity();    // M = T K, input units -> m/s^2
  Vec3 scale = Vec3::Ones();         // 1 / K: input units per m/s^2 (imu_tk's "scale")
  Vec3 misalignment = Vec3::Zero();  // T(0,1), T(0,2), T(1,2)
  Mat3 triangular() const;           // T
};

struct NormFitOptions {
  FitNoiseOptions noise;  // as the stand estimators
  int max_iterations = 100;
};

struct NormFit {
  NormCompensation compensation;
  // Standard uncertainties of bias (3), scale (3), misalignment (3), in that order and in
  // the units above, and their covariance.
  Eigen::Matrix<double, 9, 1> sigma = Eigen::Matrix<double, 9, 1>::Zero();
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  int iterations = 0;
  // Per interval: |f| - g in m/s^2 at the solution, and its standard error.
  std::vector<double> norm_residual_mps2;
  std::vector<double> norm_residual_sigma_mps2;
  double norm_residual_rms_mps2 = 0;
  // The paper's nine quantities for inputs in physical units (bias, scale-factor error and
  // the non-orthogonality pair sums of the symmetric part of M^-1 against the nominal
  // identity), with sigma, chi-square, noise and notes; for counts the nine are empty
  // (there is no nominal scale to be an error of). estimator = "norm".
  FitResult result;
};

// The interval means as PositionAverages in the calibrated frame (mean in g, standard
// errors in g, commanded angles those of the measured direction): what the invariant
// estimator and the diagnosis consume.
std::vector<PositionAverage> calibrated_averages(const std::vector<StaticInterval>& intervals,
                                                 const NormCompensation& c, double g_mps2);

// The closed-form start: the ellipsoid through the interval means (needs 9 or more).
NormCompensation ellipsoid_start(const std::vector<StaticInterval>& intervals, double g_mps2);

// Throws std::runtime_error with a plain message when there are fewer intervals than
// the nine parameters plus one of redundancy, or the fit does not converge.
NormFit fit_norm(const std::vector<StaticInterval>& intervals, double g_mps2, InputUnits units,
                 const NormFitOptions& options = {});

}  // namespace standcal
