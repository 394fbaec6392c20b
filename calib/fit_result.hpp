#pragma once
// What every estimator returns, whatever its method; serialised to the stable JSON of
// `standcal fit --json` and rendered as the bench engineer's report.
#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calib/noise_model.hpp"
#include "calib/parameters.hpp"
#include "calib/position_average.hpp"

namespace standcal {

struct ParameterEstimate {
  // Empty when the programme cannot observe the parameter (`unobservable_reason` says why).
  std::optional<double> value;  // internal units (g, dimensionless, rad)
  std::optional<double> sigma;  // 1 sigma, same units
  std::string unobservable_reason;
  // Effective degrees of freedom of sigma^2 when it rests on an estimated noise model
  // (infinite otherwise); sigma already includes Student's t widening for them.
  double dof = std::numeric_limits<double>::infinity();
};

// A named stand-error combination estimated by the full-vector method ("stand health").
struct StandEstimate {
  std::string name;
  std::string description;
  double value = 0;
  double sigma = 0;
  std::string unit;  // report unit, e.g. "arcsec"
};

struct PositionResidual {
  int pos = 0;
  double alpha1_cmd_deg = 0;
  double alpha2_cmd_deg = 0;
  Mount mount = Mount::x;
  Eigen::VectorXd residual_g;  // 1 (invariant) or 3 (full-vector) components, in g
  Eigen::VectorXd sigma_g;     // their standard errors
};

struct FitResult {
  std::string estimator;  // "joint", "paper-sequential", "full"
  int positions = 0;
  int parameters_estimated = 0;
  // Measurements - estimated parameters, the noise model's included when it is a finding
  // estimated from the same residuals: the degrees of freedom of chi2.
  int redundancy = 0;
  double chi2 = 0;
  double chi2_dof = 0;  // NaN when redundancy is zero
  double residual_rms_g = 0;
  std::array<ParameterEstimate, kUnitParameterCount> unit;
  Eigen::MatrixXd correlation;  // over the nine unit parameters, NaN rows for unobservable
  std::vector<PositionResidual> residuals;
  std::vector<StandEstimate> stand;  // full-vector only
  std::vector<std::string> notes;    // plain-language remarks (zero redundancy, ...)
  NoiseFinding noise;                // what the fit weighted with (docs/calibration.md)
};

// The covariance of the nine unit parameters from their sigmas and correlation (internal
// units); an unobservable parameter's row and column are zero.
inline Eigen::Matrix<double, kUnitParameterCount, kUnitParameterCount> unit_parameter_covariance(
    const FitResult& fit) {
  Eigen::Matrix<double, kUnitParameterCount, kUnitParameterCount> cov;
  for (int i = 0; i < kUnitParameterCount; ++i)
    for (int k = 0; k < kUnitParameterCount; ++k) {
      const ParameterEstimate& a = fit.unit[static_cast<std::size_t>(i)];
      const ParameterEstimate& b = fit.unit[static_cast<std::size_t>(k)];
      const double r = i == k                                          ? 1.0
                       : fit.correlation.rows() == kUnitParameterCount ? fit.correlation(i, k)
                                                                       : 0.0;
      const bool known = a.value && b.value && a.sigma && b.sigma && std::isfinite(r);
      cov(i, k) = known ? r * *a.sigma * *b.sigma : 0.0;
    }
  return cov;
}

}  // namespace standcal
