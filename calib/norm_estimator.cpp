#include "calib/norm_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/invariant_estimator.hpp"
#include "calib/parameters.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace {

using Vec9 = Eigen::Matrix<double, 9, 1>;
using Mat9 = Eigen::Matrix<double, 9, 9>;

constexpr int kNormParameters = 9;
constexpr int kNormMinimumIntervals = kNormParameters + 1;

NormCompensation from_triangular(const Vec3& bias, const Mat3& upper) {
  NormCompensation c;
  c.bias = bias;
  c.matrix = upper;
  for (int i = 0; i < 3; ++i) c.scale[i] = 1.0 / upper(i, i);
  c.misalignment = {upper(0, 1) / upper(1, 1), upper(0, 2) / upper(2, 2),
                    upper(1, 2) / upper(2, 2)};
  return c;
}

// The upper-triangular representative of M up to rotation: R of M = Q R, diagonal > 0.
Mat3 upper_triangular_part(const Mat3& m) {
  Mat3 r = Eigen::HouseholderQR<Mat3>(m).matrixQR().triangularView<Eigen::Upper>();
  for (int i = 0; i < 3; ++i)
    if (r(i, i) < 0) r.row(i) *= -1;
  return r;
}

// Unknowns: bias (3), K's diagonal (3), T's m01, m02, m12.
Vec9 pack(const NormCompensation& c) {
  Vec9 p;
  p << c.bias, c.scale.cwiseInverse(), c.misalignment;
  return p;
}

NormCompensation unpack(const Vec9& p) {
  Mat3 t = Mat3::Identity();
  t(0, 1) = p[6];
  t(0, 2) = p[7];
  t(1, 2) = p[8];
  const Mat3 m = t * Vec3(p.segment<3>(3)).asDiagonal();
  return from_triangular(p.head<3>(), m);
}

// Standard error of |M d| - g from the interval mean's per-axis standard errors.
double norm_sigma(const Mat3& m, const Vec3& direction, const Vec3& standard_error) {
  const Vec3 row = m.transpose() * direction;
  return std::sqrt(row.cwiseAbs2().dot(standard_error.cwiseAbs2()));
}

struct Linearised {
  Eigen::VectorXd r;  // weighted residuals
  Eigen::MatrixXd j;  // their Jacobian
};

Linearised linearise(const std::vector<StaticInterval>& intervals, const Vec9& p, double g) {
  const NormCompensation c = unpack(p);
  const Mat3 t = c.triangular();
  const Vec3 k = p.segment<3>(3);
  const auto n = static_cast<Eigen::Index>(intervals.size());
  Linearised out{Eigen::VectorXd(n), Eigen::MatrixXd(n, kNormParameters)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const StaticInterval& iv = intervals[static_cast<std::size_t>(i)];
    const Vec3 d = iv.mean - c.bias;
    const Vec3 f = c.matrix * d;
    const Vec3 u = f.normalized();
    const double w = 1.0 / std::max(norm_sigma(c.matrix, u, iv.standard_error), 1e-12 * g);
    out.r[i] = (f.norm() - g) * w;
    const Vec3 tu = t.transpose() * u;  // d|f| / d(K d) component-wise
    out.j.block<1, 3>(i, 0) = -(c.matrix.transpose() * u).transpose() * w;
    for (int a = 0; a < 3; ++a) out.j(i, 3 + a) = tu[a] * d[a] * w;
    out.j(i, 6) = u[0] * k[1] * d[1] * w;
    out.j(i, 7) = u[0] * k[2] * d[2] * w;
    out.j(i, 8) = u[1] * k[2] * d[2] * w;
  }
  return out;
}

// Gauss-Newton with Marquardt's diagonal damping.
Vec9 levenberg_marquardt(const std::vector<StaticInterval>& intervals, Vec9 p, double g,
                         int max_iterations, int& iterations) {
  double lambda = 1e-3;
  Linearised lin = linearise(intervals, p, g);
  double cost = lin.r.squaredNorm();
  if (!std::isfinite(cost))
    throw std::runtime_error(
        "norm fit: the residuals at the start are not finite numbers (a "
        "zero standard error, or interval means that are not finite)");
  for (iterations = 0; iterations < max_iterations; ++iterations) {
    const Mat9 a = lin.j.transpose() * lin.j;
    const Vec9 grad = lin.j.transpose() * lin.r;
    bool improved = false;
    Vec9 step = Vec9::Zero();
    for (int tries = 0; tries < 20 && !improved; ++tries) {
      Mat9 damped = a;
      damped.diagonal() += lambda * a.diagonal();
      step = -damped.ldlt().solve(grad);
      const Linearised trial = linearise(intervals, p + step, g);
      if (trial.r.squaredNorm() <= cost) {
        p += step;
        lin = trial;
        improved = true;
        lambda = std::max(lambda / 10, 1e-12);
      } else {
        lambda *= 10;
      }
    }
    const double new_cost = lin.r.squaredNorm();
    const bool small_step = (step.array().abs() <= 1e-12 * (p.array().abs() + 1e-12)).all();
    if (!improved || cost - new_cost <= 1e-12 * cost || small_step) {
      cost = new_cost;
      ++iterations;
      return p;
    }
    cost = new_cost;
  }
  throw std::runtime_error("norm fit: no convergence in " + std::to_string(max_iterations) +
                           " iterations (the static intervals do not fit |M (raw - b)| = g, or "
                           "their orientations do not determine the misalignments)");
}

// The invariant fit's corrections (bias in g, scale-factor errors, gamma pair sums, all in
// the calibrated frame) applied to a compensation: J = Delta + (I + dK + Gs) u, so
// f_true = (I + dK + Gs)^-1 M (raw - b - g M^-1 Delta).
NormCompensation apply_correction(const NormCompensation& c, const Vec9& e, double g) {
  Mat3 s = Mat3::Identity();
  for (int a = 0; a < 3; ++a) s(a, a) += e[3 + a];
  s(0, 1) = s(1, 0) = e[6] / 2;
  s(0, 2) = s(2, 0) = e[7] / 2;
  s(1, 2) = s(2, 1) = e[8] / 2;
  const Mat3 m = s.inverse() * c.matrix;
  const Vec3 bias = c.bias + c.matrix.inverse() * (g * e.head<3>());
  return from_triangular(bias, upper_triangular_part(m));
}

// The paper's nine quantities of the raw outputs: J_raw = raw / unit = Delta + P R u with
// P the symmetric part (polar decomposition) of (g / unit) M^-1.
Vec9 paper_quantities(const NormCompensation& c, double g, InputUnits units) {
  const double unit = units == InputUnits::g ? 1.0 : g;
  const Mat3 n = (g / unit) * c.matrix.inverse();
  Eigen::JacobiSVD<Mat3> svd(n, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3 p = svd.matrixU() * svd.singularValues().asDiagonal() * svd.matrixU().transpose();
  Vec9 q;
  q << c.bias / unit, p(0, 0) - 1, p(1, 1) - 1, p(2, 2) - 1, 2 * p(0, 1), 2 * p(0, 2), 2 * p(1, 2);
  return q;
}

// Jacobian of f(correction) at zero by central differences (the maps are smooth and
// nearly linear over a sigma).
template <typename F>
Mat9 jacobian_at_zero(F f) {
  Mat9 j;
  constexpr double h = 1e-7;
  for (int k = 0; k < kNormParameters; ++k) {
    Vec9 e = Vec9::Zero();
    e[k] = h;
    j.col(k) = (f(e) - f(-e)) / (2 * h);
  }
  return j;
}

void require_enough(const std::vector<StaticInterval>& intervals) {
  if (static_cast<int>(intervals.size()) >= kNormMinimumIntervals) return;
  throw std::runtime_error(
      "cannot calibrate and check the model: " + std::to_string(intervals.size()) +
      " static intervals, and the attitude-free fit needs at least " +
      std::to_string(kNormMinimumIntervals) +
      " (nine parameters plus one to check the model against); record more orientations, "
      "ideally 15 or more spread over the sphere");
}

void require_observable(const FitResult& r) {
  std::string missing;
  for (int k = 0; k < kNormParameters; ++k)
    if (!r.unit[static_cast<std::size_t>(k)].value)
      missing += (missing.empty() ? "" : ", ") +
                 std::string(kUnitParameterNames[static_cast<std::size_t>(k)]);
  if (!missing.empty())
    throw std::runtime_error(
        "cannot calibrate: the orientations of the static intervals do not "
        "determine " +
        missing + " (hold the unit in orientations between the axes, not only along them)");
}

// Two intervals whose directions of gravity, in the unit's raw axes, lie within this angle
// hold the unit in one orientation: well above a unit's misalignments (0.02 rad is 1.1
// degrees) and the noise of a static mean.
constexpr double kSameOrientationDeg = 5;

// The nine parameters need gravity in at least nine distinct directions: intervals repeated
// in fewer (a stand programme like classic24 read without its angles, 24 dwells in the six
// directions +-x, +-y, +-z) leave the ellipsoid's cross terms, and so the misalignments, to
// the noise. Noise-free, ellipsoid_start refuses them; with noise it fits the noise, and the
// search wandered: "no convergence in 100 iterations (the static intervals do not fit ...)",
// which blamed the data. The directions are read with each axis centred and scaled by its
// own range, which no misalignment or undetermined cross term changes much.
void require_distinct_orientations(const std::vector<StaticInterval>& intervals) {
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  for (const StaticInterval& iv : intervals) {
    low = low.cwiseMin(iv.mean);
    high = high.cwiseMax(iv.mean);
  }
  const Vec3 centre = (low + high) / 2, half_range = (high - low) / 2;
  // An axis that never moves: the ellipsoid start says what is wrong with it.
  if (!half_range.allFinite() || (half_range.array() <= 0).any()) return;
  const double same = std::cos(kSameOrientationDeg * kDegToRad);
  std::vector<Vec3> orientations;
  for (const StaticInterval& iv : intervals) {
    const Vec3 u = (iv.mean - centre).cwiseQuotient(half_range).normalized();
    const auto seen = [&](const Vec3& o) { return u.dot(o) > same; };
    if (u.allFinite() && std::none_of(orientations.begin(), orientations.end(), seen))
      orientations.push_back(u);
  }
  if (static_cast<int>(orientations.size()) >= kNormParameters) return;
  throw std::runtime_error(
      "cannot calibrate: the " + std::to_string(intervals.size()) +
      " static intervals hold the unit in only " + std::to_string(orientations.size()) +
      " distinct orientations (gravity within " +
      std::to_string(static_cast<int>(kSameOrientationDeg)) +
      " degrees counts as one), and the attitude-free fit's nine parameters need at least " +
      std::to_string(kNormParameters) +
      ": with fewer the misalignments are not determined (hold the unit in more orientations, "
      "between the axes as well as along them)");
}

// The nine paper quantities with their sigmas replace the invariant corrections.
void report_paper_quantities(FitResult& r, const Vec9& q, const Mat9& cov, InputUnits units) {
  const Vec9 sigma = cov.diagonal().cwiseSqrt();
  for (int k = 0; k < kNormParameters; ++k) {
    ParameterEstimate& p = r.unit[static_cast<std::size_t>(k)];
    if (units == InputUnits::counts) {
      p = ParameterEstimate{};
      p.unobservable_reason =
          "input in counts: no nominal scale to be an error of (see compensation)";
      continue;
    }
    p.value = q[k];
    p.sigma = sigma[k];
  }
  r.correlation = units == InputUnits::counts
                      ? Eigen::MatrixXd::Constant(kNormParameters, kNormParameters, kNaN)
                      : Eigen::MatrixXd((sigma.cwiseInverse().asDiagonal() * cov) *
                                        sigma.cwiseInverse().asDiagonal());
}

}  // namespace

Mat3 NormCompensation::triangular() const {
  Mat3 t = Mat3::Identity();
  t(0, 1) = misalignment[0];
  t(0, 2) = misalignment[1];
  t(1, 2) = misalignment[2];
  return t;
}

NormCompensation ellipsoid_start(const std::vector<StaticInterval>& intervals, double g) {
  const auto n = static_cast<Eigen::Index>(intervals.size());
  if (n < kNormParameters) require_enough(intervals);
  // Centre and scale the means first: raw counts near 33000 would make the quadric's
  // columns differ by 10^9 and the SVD lose the small ones.
  Vec3 centre = Vec3::Zero();
  for (const StaticInterval& iv : intervals) centre += iv.mean;
  centre /= static_cast<double>(n);
  double spread = 0;
  for (const StaticInterval& iv : intervals) spread += (iv.mean - centre).squaredNorm();
  spread = std::sqrt(spread / static_cast<double>(n));
  Eigen::MatrixXd d(n, 10);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 x = (intervals[static_cast<std::size_t>(i)].mean - centre) / spread;
    d.row(i) << x[0] * x[0], x[1] * x[1], x[2] * x[2], 2 * x[0] * x[1], 2 * x[0] * x[2],
        2 * x[1] * x[2], 2 * x[0], 2 * x[1], 2 * x[2], 1;
  }
  // x'Ax + 2v'x + c = 0 with the coefficient vector of unit length: the smallest right
  // singular vector.
  const Eigen::VectorXd th =
      Eigen::JacobiSVD<Eigen::MatrixXd>(d, Eigen::ComputeFullV).matrixV().col(9);
  Mat3 a;
  a << th[0], th[3], th[4], th[3], th[1], th[5], th[4], th[5], th[2];
  const Vec3 v = th.segment<3>(6);
  const Vec3 b = -a.ldlt().solve(v);
  const double k = b.dot(a * b) - th[9];
  const Mat3 shape = a / k / (spread * spread) * (g * g);  // M'M in input units
  Eigen::LLT<Mat3> llt(shape);
  if (!shape.allFinite() || llt.info() != Eigen::Success ||
      !llt.matrixL().toDenseMatrix().allFinite())
    throw std::runtime_error(
        "cannot calibrate: the static interval means do not lie on an "
        "ellipsoid (too few distinct orientations, or intervals that were not static)");
  return from_triangular(centre + spread * b, llt.matrixL().transpose());
}

std::vector<PositionAverage> calibrated_averages(const std::vector<StaticInterval>& intervals,
                                                 const NormCompensation& c, double g) {
  std::vector<PositionAverage> out;
  int index = 0;
  for (const StaticInterval& iv : intervals) {
    PositionAverage p;
    p.pos = index++;
    p.mean_g = c.matrix * (iv.mean - c.bias) / g;
    const Vec3 u = p.mean_g.normalized();
    // The measured direction as stand angles: u = [sin a1, cos a1 cos a2, cos a1 sin a2].
    p.alpha1_cmd_deg = std::asin(std::clamp(u[0], -1.0, 1.0)) * kRadToDeg;
    p.alpha2_cmd_deg = std::atan2(u[2], u[1]) * kRadToDeg;
    const Mat3 m2 = c.matrix.cwiseAbs2() / (g * g);
    p.standard_error_g = (m2 * iv.standard_error.cwiseAbs2()).cwiseSqrt();
    p.sigma_g = (m2 * iv.sigma.cwiseAbs2()).cwiseSqrt();
    p.samples = iv.samples;
    p.t_start_s = iv.t_start_s;
    p.t_end_s = iv.t_end_s;
    p.t_arrive_s = iv.t_start_s;
    p.temp_mean_c = kNaN;
    out.push_back(p);
  }
  return out;
}

NormFit fit_norm(const std::vector<StaticInterval>& intervals, double g, InputUnits units,
                 const NormFitOptions& o) {
  require_enough(intervals);
  require_distinct_orientations(intervals);
  NormFit fit;
  const Vec9 start = pack(ellipsoid_start(intervals, g));
  const NormCompensation solved =
      unpack(levenberg_marquardt(intervals, start, g, o.max_iterations, fit.iterations));
  // Sigmas, chi-square and the noise model from the linearised problem at the solution;
  // its corrections (GLS when the run shows wander) are applied.
  FitNoiseOptions noise = o.noise;
  noise.estimate_from_full_vector = false;  // the attitudes are the means' own directions
  noise.average_over_wander_sizes = true;   // its rows cannot tell white noise from a 1x wander
  FitResult inv = fit_invariant_joint(calibrated_averages(intervals, solved, g), noise);
  require_observable(inv);
  const Mat9 cov_correction = unit_parameter_covariance(inv);  // all observable (above)
  Vec9 correction;
  for (int k = 0; k < kNormParameters; ++k)
    correction[k] = *inv.unit[static_cast<std::size_t>(k)].value;
  fit.compensation = apply_correction(solved, correction, g);
  const auto corrected = [&](const Vec9& e) { return apply_correction(fit.compensation, e, g); };
  const Mat9 j_comp = jacobian_at_zero([&](const Vec9& e) {
    const NormCompensation c = corrected(e);
    Vec9 v;
    v << c.bias, c.scale, c.misalignment;
    return v;
  });
  fit.covariance = j_comp * cov_correction * j_comp.transpose();
  fit.sigma = fit.covariance.diagonal().cwiseSqrt();
  const Mat9 j_paper =
      jacobian_at_zero([&](const Vec9& e) { return paper_quantities(corrected(e), g, units); });
  fit.result = std::move(inv);
  fit.result.estimator = "norm";
  report_paper_quantities(fit.result, paper_quantities(fit.compensation, g, units),
                          j_paper * cov_correction * j_paper.transpose(), units);
  const std::vector<PositionAverage> final_avg =
      calibrated_averages(intervals, fit.compensation, g);
  double sum2 = 0;
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    const double r = (final_avg[i].mean_g.norm() - 1) * g;
    fit.norm_residual_mps2.push_back(r);
    fit.norm_residual_sigma_mps2.push_back(norm_sigma(
        fit.compensation.matrix, final_avg[i].mean_g.normalized(), intervals[i].standard_error));
    sum2 += r * r;
  }
  fit.norm_residual_rms_mps2 = std::sqrt(sum2 / static_cast<double>(intervals.size()));
  return fit;
}

}  // namespace standcal
