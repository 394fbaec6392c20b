#pragma once
// Bias wander between dwells (model.md `bias_instability`): a Gauss-Markov bias per
// accelerometer axis, b_a(t) with variance q_a^2 and correlation exp(-|dt| / tau), under
// the white noise that each dwell mean's standard error describes. Wander correlated over
// minutes does not average down inside a 10 s dwell nor across positions, so the means of
// dwells close in time share it; their covariance is
//   C(r, s) = sigma_r^2 delta_rs + sum_a P_r[a] P_s[a] q_a^2 exp(-|t_r - t_s| / tau)
// where row r is one projection P_r of one dwell mean (e_a for a full-vector component,
// u for the invariant projection).
//
// The wander is a 3-state linear system, so a Kalman filter over the rows in time order
// turns any column into its innovations: exactly C^{-1/2} (the Cholesky factor's inverse),
// in O(rows) rather than O(rows^3). The diagnosis and the estimators work on that
// decorrelated problem (generalised least squares) and estimate q and tau from it by
// restricted maximum likelihood (REML), which does not count the fitted parameters'
// share of the residual as noise.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "calib/model.hpp"

namespace standcal {

// What the noise model needs to know of one row of a whitened linear problem.
struct NoiseRow {
  double t_s = 0;                  // mid-time of the dwell
  Vec3 projection = Vec3::Zero();  // which combination of the three axes the row measures
  double sigma_g = 0;              // white standard error of the row (g): its whitening
};

struct GaussMarkovNoise {
  Vec3 q_g = Vec3::Zero();  // stationary standard deviation of the wander, per axis (g)
  double tau_s = 0;         // correlation time
  bool white() const { return q_g.isZero(); }
};

// C^{-1/2} M for the rows' covariance under `noise`, where M's rows are already whitened
// by sigma (row r divided by sigma_r): returns the innovations of each column, normalised
// to unit variance. log_det_out, when given, receives log |C_w| (C in whitened units).
Eigen::MatrixXd decorrelate(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise,
                            const Eigen::MatrixXd& whitened, double* log_det_out = nullptr);

struct NoiseEstimate {
  GaussMarkovNoise noise;   // white (q = 0) unless the wander is significant
  GaussMarkovNoise best;    // the REML optimum, significant or not
  double lr = 0;            // 2 (restricted log-likelihood(best) - log-likelihood(white))
  double lr_threshold = 0;  // lr needed to call the wander significant
  bool significant = false;
  std::string how;  // how it was obtained, in words
};

struct NoiseEstimateOptions {
  std::vector<double> tau_grid_s{60, 150, 300, 600, 1200};
  // 2 delta log L of the wander model over white noise for it to be believed: chi2 with
  // four parameters (three q, one tau) at P = 1e-3 is 18.5.
  double lr_threshold = 18.5;
};

// REML estimate of the wander for the linear model y = X beta + e (both already whitened
// by sigma; X's column space is the fitted model). Per-axis q by coordinate-wise golden
// section on log q for each tau of the grid.
NoiseEstimate estimate_bias_wander(const std::vector<NoiseRow>& rows, const Eigen::MatrixXd& X,
                                   const Eigen::VectorXd& y,
                                   const NoiseEstimateOptions& options = {});

// The peak of the Allan deviation of a Gauss-Markov process (q, tau): the "bias
// instability floor" an Allan plot of this wander would show, and the averaging time at
// which it is reached.
struct AllanPeak {
  double deviation = 0;
  double tau_s = 0;
};
AllanPeak gauss_markov_allan_peak(double q, double tau_s);

}  // namespace standcal
