#include "calib/diagnosis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <stdexcept>

#include "calib/averaging.hpp"
#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/report.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
const char* const kAxisNames[3] = {"x", "y", "z"};

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// What the diagnosis knows about one position besides its mean.
struct PositionContext {
  Vec3 up = Vec3::Zero();
  double alpha1_deg = 0, alpha2_deg = 0;  // commanded
  Mount mount = Mount::x;
  double t_mid_h = 0;
  double temp_delta_c = 0;  // T - temp_ref
  int approach = 1;
};

// The baseline linearised around its fit: whitened residuals y and whitened design A.
// Candidate terms are added as further columns; rows are grouped by position.
struct LinearProblem {
  bool full = true;
  VectorXd y;
  MatrixXd A;
  std::vector<int> unit_column;  // column of A for each of the 9 unit parameters, or -1
  std::vector<double> row_sigma_g;
  std::vector<int> row_position;
  std::vector<int> row_axis;     // 0..2 (full) or -1 (invariant projection)
  int positions = 0;
};

// A catalog candidate: its id, axis and its contribution to J (g per report unit).
struct Candidate {
  std::string effect, axis, unit;
  int out_axis = 0, other_axis = -1;
  int params = 1;  // angle_sensor_error: 2, the sine and cosine parts of the cyclic error
};

// d u / d alpha_k (per rad) at a commanded pose, in instrument axes (model.md's u).
Vec3 up_derivative(const PositionContext& p, bool outer) {
  const double a1 = p.alpha1_deg * kDegToRad, a2 = p.alpha2_deg * kDegToRad;
  const Vec3 d_table = outer ? Vec3(std::cos(a1), -std::sin(a1) * std::cos(a2), -std::sin(a1) * std::sin(a2))
                             : Vec3(0, -std::cos(a1) * std::sin(a2), std::cos(a1) * std::cos(a2));
  return mount_permutation(p.mount) * d_table;
}

// The candidate's contribution to J (g) per report unit of each of its parameters:
// 3 x params. angle_sensor_error: the true angle is the reading + a sin(alpha) + b cos(alpha)
// (arcsec), which turns the up vector by du/dalpha times that (first order).
MatrixXd candidate_effect_g(const Candidate& c, const PositionContext& p) {
  MatrixXd e = MatrixXd::Zero(3, c.params);
  if (c.effect == "angle_sensor_error") {
    const bool outer = c.axis == "alpha1";
    const double alpha_rad = (outer ? p.alpha1_deg : p.alpha2_deg) * kDegToRad;
    const Vec3 du = up_derivative(p, outer) * kArcsecToRad;
    e.col(0) = du * std::sin(alpha_rad);
    e.col(1) = du * std::cos(alpha_rad);
    return e;
  }
  const int i = c.out_axis;
  const double ui = p.up[i];
  double v = 0;
  if (c.effect == "scale_nonlinearity_k2") v = ui * ui;
  else if (c.effect == "scale_nonlinearity_k3") v = ui * ui * ui;
  else if (c.effect == "cross_coupling") v = ui * p.up[c.other_axis];
  else if (c.effect == "bias_temperature") v = p.temp_delta_c;
  else if (c.effect == "scale_temperature") v = p.temp_delta_c * ui;
  else if (c.effect == "bias_drift") v = p.t_mid_h;
  else if (c.effect == "hysteresis") v = p.approach;
  e(i, 0) = v * 1e-6;
  return e;
}

std::vector<Candidate> catalog_candidates(bool have_temperature) {
  std::vector<Candidate> out;
  for (int i = 0; i < 3; ++i) {
    const std::string a = kAxisNames[i];
    out.push_back({"scale_nonlinearity_k2", a, "ug/g2", i});
    out.push_back({"scale_nonlinearity_k3", a, "ug/g3", i});
    out.push_back({"bias_drift", a, "ug/h", i});
    out.push_back({"hysteresis", a, "ug", i});
    if (have_temperature) {
      out.push_back({"bias_temperature", a, "ug/degC", i});
      out.push_back({"scale_temperature", a, "ppm/degC", i});
    }
    for (int j = 0; j < 3; ++j)
      if (j != i) out.push_back({"cross_coupling", a + kAxisNames[j], "ug/g2", i, j});
  }
  for (const char* stand_axis : {"alpha1", "alpha2"}) out.push_back({"angle_sensor_error", stand_axis, "arcsec", 0, -1, 2});
  return out;
}

// The candidate's whitened columns (rows of lp x params).
MatrixXd candidate_columns(const Candidate& c, const LinearProblem& lp, const std::vector<PositionContext>& ctx) {
  MatrixXd cols(lp.y.size(), c.params);
  for (Eigen::Index r = 0; r < cols.rows(); ++r) {
    const PositionContext& p = ctx[static_cast<std::size_t>(lp.row_position[static_cast<std::size_t>(r)])];
    const MatrixXd e = candidate_effect_g(c, p);
    const int axis = lp.row_axis[static_cast<std::size_t>(r)];
    const Eigen::RowVectorXd value = axis >= 0 ? Eigen::RowVectorXd(e.row(axis)) : Eigen::RowVectorXd(p.up.transpose() * e);
    cols.row(r) = value / lp.row_sigma_g[static_cast<std::size_t>(r)];
  }
  return cols;
}

// Weighted least squares on whitened data with columns scaled to unit norm (the design
// mixes 1/sigma ~ 1e6 with candidate columns ~ 1; scaling keeps the rank decision sane).
struct LinearFit {
  VectorXd beta;      // in the original column units
  MatrixXd cov;       // of beta
  VectorXd residual;  // whitened
  double chi2 = 0;
  int rank = 0;
  int dof = 0;
  VectorXd press;     // per position, NaN where the position cannot be predicted without itself
};

// No column (nothing fitted) or no row: the residual is the data itself. Eigen's
// decompositions must never see an empty matrix (a zero-column QR segfaulted; issue 14).
LinearFit empty_linear_fit(const MatrixXd& X, const VectorXd& y, int positions) {
  LinearFit f;
  f.beta = VectorXd::Zero(X.cols());
  f.cov = MatrixXd::Zero(X.cols(), X.cols());
  f.residual = y;
  f.chi2 = y.squaredNorm();
  f.dof = static_cast<int>(y.size());
  f.press = VectorXd::Constant(positions, kNaN);
  return f;
}

LinearFit solve_linear(const MatrixXd& X, const VectorXd& y, const std::vector<int>& row_position, int positions) {
  if (X.cols() == 0 || X.rows() == 0) return empty_linear_fit(X, y, positions);
  LinearFit f;
  VectorXd norms = X.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < norms.size(); ++j)
    if (norms[j] <= 0) norms[j] = 1;
  const MatrixXd Xn = X * norms.cwiseInverse().asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(Xn);
  cod.setThreshold(1e-10);
  f.rank = static_cast<int>(cod.rank());
  const VectorXd bn = cod.solve(y);
  f.beta = bn.cwiseQuotient(norms);
  f.residual = y - Xn * bn;
  f.chi2 = f.residual.squaredNorm();
  f.dof = static_cast<int>(y.size()) - f.rank;
  const MatrixXd pinv = cod.pseudoInverse();
  const MatrixXd covn = pinv * pinv.transpose();
  f.cov = norms.cwiseInverse().asDiagonal() * covn * norms.cwiseInverse().asDiagonal();
  // Leave-one-position-out prediction residuals from the hat matrix, block by block.
  const MatrixXd H = Xn * pinv;
  f.press = VectorXd::Constant(positions, kNaN);
  for (int k = 0; k < positions; ++k) {
    std::vector<Eigen::Index> rows;
    for (std::size_t r = 0; r < row_position.size(); ++r)
      if (row_position[r] == k) rows.push_back(static_cast<Eigen::Index>(r));
    const auto n = static_cast<Eigen::Index>(rows.size());
    MatrixXd M = MatrixXd::Identity(n, n);
    VectorXd e(n);
    for (Eigen::Index a = 0; a < n; ++a) {
      e[a] = f.residual[rows[static_cast<std::size_t>(a)]];
      for (Eigen::Index b = 0; b < n; ++b) M(a, b) -= H(rows[static_cast<std::size_t>(a)], rows[static_cast<std::size_t>(b)]);
    }
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(M);
    if (es.eigenvalues().minCoeff() < 1e-6) continue;
    f.press[k] = M.ldlt().solve(e).squaredNorm();
  }
  return f;
}

// Held-out chi2 gain of `after` over `before`, over positions both can predict.
double press_gain(const LinearFit& before, const LinearFit& after) {
  double gain = 0;
  for (Eigen::Index k = 0; k < before.press.size(); ++k)
    if (std::isfinite(before.press[k]) && std::isfinite(after.press[k])) gain += before.press[k] - after.press[k];
  return gain;
}

double consistency_p(double chi2, int dof) { return dof > 0 ? chi2_upper_tail(chi2, dof) : 1.0; }

std::vector<PositionContext> position_contexts(const std::vector<PositionAverage>& avg, double temp_ref_c) {
  std::vector<PositionContext> ctx;
  for (const PositionAverage& p : avg) {
    PositionContext c;
    c.up = p.up();
    c.alpha1_deg = p.alpha1_cmd_deg;
    c.alpha2_deg = p.alpha2_cmd_deg;
    c.mount = p.mount;
    c.t_mid_h = 0.5 * (p.t_start_s + p.t_end_s) / 3600.0;
    c.temp_delta_c = std::isfinite(p.temp_mean_c) ? p.temp_mean_c - temp_ref_c : 0.0;
    c.approach = p.approach;
    ctx.push_back(c);
  }
  return ctx;
}

std::vector<StandPose> poses_of(const std::vector<PositionAverage>& avg) {
  std::vector<StandPose> poses;
  for (const auto& p : avg) poses.push_back({p.alpha1_cmd_deg, p.alpha2_cmd_deg, p.mount});
  return poses;
}

// The full-vector baseline, linearised at the nominal point (stand and unit errors are
// small, so the Jacobian there differs from the one at the fit by second-order terms).
struct FullDesign {
  FullModelLayout layout;
  Observability obs;
};

FullDesign full_design(const std::vector<PositionAverage>& avg) {
  const std::vector<StandPose> poses = poses_of(avg);
  std::vector<double> weights;
  for (const auto& p : avg) weights.push_back(1.0 / p.standard_error_g.cwiseMax(1e-9).mean());
  FullDesign d;
  d.layout = full_model_layout(poses);
  d.obs = analyse_observability(d.layout, poses, weights, 1e-6);
  return d;
}

Eigen::RowVectorXd full_design_row(const FullDesign& d, const StandPose& pose, int axis) {
  const MatrixXd J = full_model_jacobian(d.layout, VectorXd::Zero(d.layout.size()), pose);
  Eigen::RowVectorXd row(static_cast<Eigen::Index>(d.obs.kept.size()));
  for (std::size_t j = 0; j < d.obs.kept.size(); ++j) row[static_cast<Eigen::Index>(j)] = J(axis, d.obs.kept[j]);
  return row;
}

LinearProblem full_problem(const std::vector<PositionAverage>& avg, const FitResult& fit, const FullDesign& d) {
  LinearProblem lp;
  lp.full = true;
  lp.positions = static_cast<int>(avg.size());
  const auto m = static_cast<Eigen::Index>(3 * avg.size());
  lp.y.resize(m);
  lp.A.resize(m, static_cast<Eigen::Index>(d.obs.kept.size()));
  for (std::size_t k = 0; k < avg.size(); ++k) {
    const StandPose pose{avg[k].alpha1_cmd_deg, avg[k].alpha2_cmd_deg, avg[k].mount};
    const MatrixXd J = full_model_jacobian(d.layout, VectorXd::Zero(d.layout.size()), pose);
    for (int a = 0; a < 3; ++a) {
      const auto r = static_cast<Eigen::Index>(3 * k) + a;
      const double s = std::max(avg[k].standard_error_g[a], 1e-9);
      lp.y[r] = fit.residuals[k].residual_g[a] / s;
      for (std::size_t j = 0; j < d.obs.kept.size(); ++j) lp.A(r, static_cast<Eigen::Index>(j)) = J(a, d.obs.kept[j]) / s;
      lp.row_sigma_g.push_back(s);
      lp.row_position.push_back(static_cast<int>(k));
      lp.row_axis.push_back(a);
    }
  }
  lp.unit_column.assign(kUnitParameterCount, -1);
  for (std::size_t j = 0; j < d.obs.kept.size(); ++j)
    if (d.obs.kept[j] < kUnitParameterCount) lp.unit_column[static_cast<std::size_t>(d.obs.kept[j])] = static_cast<int>(j);
  return lp;
}

LinearProblem invariant_problem(const std::vector<PositionAverage>& avg, const FitResult& fit) {
  LinearProblem lp;
  lp.full = false;
  lp.positions = static_cast<int>(avg.size());
  const auto m = static_cast<Eigen::Index>(avg.size());
  lp.y.resize(m);
  MatrixXd A(m, kUnitParameterCount);
  for (std::size_t k = 0; k < avg.size(); ++k) {
    const double s = invariant_sigma_g(avg[k]);
    const auto r = static_cast<Eigen::Index>(k);
    lp.y[r] = fit.residuals[k].residual_g[0] / s;
    A.row(r) = invariant_regressor(avg[k].up()) / s;
    lp.row_sigma_g.push_back(s);
    lp.row_position.push_back(static_cast<int>(k));
    lp.row_axis.push_back(-1);
  }
  // Keep only the regressors the programme excites (classic24 has no gamma regressors).
  lp.unit_column.assign(kUnitParameterCount, -1);
  std::vector<Eigen::Index> keep;
  for (int j = 0; j < kUnitParameterCount; ++j)
    if (fit.unit[static_cast<std::size_t>(j)].value) {
      lp.unit_column[static_cast<std::size_t>(j)] = static_cast<int>(keep.size());
      keep.push_back(j);
    }
  lp.A.resize(m, static_cast<Eigen::Index>(keep.size()));
  for (std::size_t j = 0; j < keep.size(); ++j) lp.A.col(static_cast<Eigen::Index>(j)) = A.col(keep[j]);
  return lp;
}

MatrixXd with_columns(const MatrixXd& A, const std::vector<VectorXd>& cols) {
  MatrixXd X(A.rows(), A.cols() + static_cast<Eigen::Index>(cols.size()));
  X.leftCols(A.cols()) = A;
  for (std::size_t j = 0; j < cols.size(); ++j) X.col(A.cols() + static_cast<Eigen::Index>(j)) = cols[j];
  return X;
}

// ---- settling transient: inside each dwell, on the raw samples -------------------------

struct SettlingResult {
  int axis = 0;
  double tau_s = 0, amplitude_ug = 0, sigma_ug = 0, delta_chi2 = 0, press_gain = 0;
  // sigma of the amplitude when tau is estimated too (from the same samples): the
  // amplitude and tau are correlated, and the reported sigma must carry that.
  double sigma_free_tau_ug = 0;
  std::vector<double> mean_shape;  // per position: dwell mean of exp(-(t - t_arrive) / tau)
};

// Per axis and tau: within-dwell residuals (sample - position mean) regressed on the
// de-meaned exp(-(t - t_arrive)/tau) together with a de-meaned linear trend (which a
// bias drift leaves inside a dwell, and which must not count as a transient). A third
// column, the shape's derivative by tau, gives the amplitude's sigma with tau free.
SettlingResult settling_search(const Recording& rec, const std::vector<PositionAverage>& avg, int axis, double tau_s) {
  SettlingResult res;
  res.axis = axis;
  res.tau_s = tau_s;
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < avg.size(); ++k) index[avg[k].pos] = k;
  const std::size_t npos = avg.size();
  std::vector<double> sum_e(npos, 0), sum_de(npos, 0), sum_t(npos, 0), count(npos, 0);
  const double g = rec.g_local_mps2;
  for (const RecordingSample& s : rec.samples) {
    const std::size_t k = index.at(s.pos);
    const double since = s.t_s - avg[k].t_arrive_s;
    const double e = std::exp(-since / tau_s);
    sum_e[k] += e;
    sum_de[k] += e * since / (tau_s * tau_s);
    sum_t[k] += s.t_s;
    count[k] += 1;
  }
  res.mean_shape.resize(npos);
  // Normal equations of [shape, trend, d shape / d tau] per position, accumulated (for
  // leave-one-out); the first two are the test, the third only widens the sigma.
  using Mat3d = Eigen::Matrix3d;
  std::vector<Mat3d> N(npos, Mat3d::Zero());
  std::vector<Eigen::Vector3d> b(npos, Eigen::Vector3d::Zero());
  std::vector<double> rr(npos, 0);
  for (const RecordingSample& s : rec.samples) {
    const std::size_t k = index.at(s.pos);
    const double sig = std::max(avg[k].sigma_g[axis], 1e-9);
    const double since = s.t_s - avg[k].t_arrive_s;
    const double ex = std::exp(-since / tau_s);
    const double e = ex - sum_e[k] / count[k];
    const double de = ex * since / (tau_s * tau_s) - sum_de[k] / count[k];
    const double t = (s.t_s - sum_t[k] / count[k]) / 60.0;
    const double r = (s.f_mps2[axis] / g - avg[k].mean_g[axis]) / sig;
    const Eigen::Vector3d x(e / sig, t / sig, de / sig);
    N[k] += x * x.transpose();
    b[k] += x * r;
    rr[k] += r * r;
  }
  Mat3d N3 = Mat3d::Zero();
  Eigen::Vector3d b3 = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < npos; ++k) {
    N3 += N[k];
    b3 += b[k];
    res.mean_shape[k] = sum_e[k] / count[k];
  }
  const Eigen::Matrix2d Nt = N3.topLeftCorner<2, 2>();
  const Eigen::Vector2d bt = b3.head<2>();
  if (std::abs(Nt.determinant()) < 1e-30 || Nt(0, 0) <= 0) return res;
  // chi2 gain of the transient over the trend alone.
  const Eigen::Vector2d beta = Nt.ldlt().solve(bt);
  const double gain_both = beta.dot(bt);
  const double gain_trend = Nt(1, 1) > 0 ? bt[1] * bt[1] / Nt(1, 1) : 0;
  res.delta_chi2 = gain_both - gain_trend;
  const Eigen::Matrix2d cov = Nt.inverse();
  res.amplitude_ug = beta[0] / kUg;
  res.sigma_ug = std::sqrt(cov(0, 0)) / kUg;
  res.sigma_free_tau_ug = res.sigma_ug;
  if (N3(2, 2) > 0) {
    // Invert on the correlation scale, so the conditioning test means something.
    const Eigen::Vector3d d = N3.diagonal().cwiseSqrt().cwiseInverse();
    const Mat3d R = d.asDiagonal() * N3 * d.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Mat3d> es(R);
    if (es.eigenvalues().minCoeff() > 1e-10) {
      const double v = R.inverse()(0, 0) * d[0] * d[0];
      res.sigma_free_tau_ug = std::max(res.sigma_ug, std::sqrt(v) / kUg);
    }
  }
  // Leave one position out: predict its within-dwell residuals from the others.
  for (std::size_t k = 0; k < npos; ++k) {
    const Eigen::Matrix2d Nk = Nt - N[k].topLeftCorner<2, 2>();
    const Eigen::Vector2d bk_sum = bt - b[k].head<2>();
    if (std::abs(Nk.determinant()) < 1e-30 || Nk(1, 1) <= 0) continue;
    const Eigen::Vector2d bk = Nk.ldlt().solve(bk_sum);
    const Eigen::Matrix2d Nkk = N[k].topLeftCorner<2, 2>();
    const Eigen::Vector2d bkk = b[k].head<2>();
    const double trend_only = bk_sum[1] / Nk(1, 1);
    const double with = rr[k] - 2 * bk.dot(bkk) + bk.dot(Nkk * bk);
    const double without = rr[k] - 2 * trend_only * bkk[1] + trend_only * trend_only * Nkk(1, 1);
    res.press_gain += without - with;
  }
  return res;
}

// The best settling transient of one axis: the tau grid, then a golden-section refinement
// of log tau between the best grid point's neighbours (only when the grid found something
// worth refining: the refinement costs passes over the raw samples).
SettlingResult best_settling(const Recording& rec, const std::vector<PositionAverage>& avg, int axis,
                             const std::vector<double>& tau_grid_s, double refine_above_chi2) {
  SettlingResult best;
  std::size_t best_i = 0;
  for (std::size_t i = 0; i < tau_grid_s.size(); ++i) {
    const SettlingResult r = settling_search(rec, avg, axis, tau_grid_s[i]);
    if (r.delta_chi2 > best.delta_chi2) { best = r; best_i = i; }
  }
  if (best.delta_chi2 <= refine_above_chi2 || tau_grid_s.size() < 2) return best;
  double lo = std::log(tau_grid_s[best_i > 0 ? best_i - 1 : 0]);
  double hi = std::log(tau_grid_s[std::min(best_i + 1, tau_grid_s.size() - 1)]);
  const double phi = 0.5 * (std::sqrt(5.0) - 1);
  auto eval = [&](double log_tau) { return settling_search(rec, avg, axis, std::exp(log_tau)); };
  double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
  SettlingResult r1 = eval(x1), r2 = eval(x2);
  for (int it = 0; it < 12; ++it) {
    if (r1.delta_chi2 > r2.delta_chi2) {
      hi = x2; x2 = x1; r2 = r1; x1 = hi - phi * (hi - lo); r1 = eval(x1);
    } else {
      lo = x1; x1 = x2; r1 = r2; x2 = lo + phi * (hi - lo); r2 = eval(x2);
    }
  }
  const SettlingResult& refined = r1.delta_chi2 > r2.delta_chi2 ? r1 : r2;
  return refined.delta_chi2 > best.delta_chi2 ? refined : best;
}

// ---- words -------------------------------------------------------------------------------

std::string effect_words(const std::string& id, const std::string& axis) {
  const std::string ax = axis.size() == 1 ? "the " + axis + " accelerometer" : "";
  if (id == "scale_nonlinearity_k2") return "second-order scale-factor nonlinearity K2 of " + ax;
  if (id == "scale_nonlinearity_k3") return "third-order scale-factor nonlinearity K3 of " + ax;
  if (id == "cross_coupling")
    return std::string("cross-coupling K_") + axis + " (a_" + axis.substr(0, 1) + "*a_" + axis.substr(1, 1) +
           " on the " + axis.substr(0, 1) + " output)";
  if (id == "bias_temperature") return "bias temperature coefficient of " + ax;
  if (id == "scale_temperature") return "scale-factor temperature coefficient of " + ax;
  if (id == "bias_drift") return "bias drift of " + ax;
  if (id == "hysteresis") return "approach-direction hysteresis of " + ax;
  if (id == "settling_transient") return "settling transient after each move on " + ax;
  if (id == "angle_sensor_error")
    return std::string("cyclic (once per revolution) error of the ") + (axis == "alpha1" ? "outer" : "inner") +
           "-axis angle sensor";
  if (id == "mounting_misalignment_large") return "large mounting misalignment about " + axis;
  return id;
}

std::string signature_words(const std::string& id, const std::string& axis) {
  const std::string a = axis.substr(0, 1);
  if (id == "scale_nonlinearity_k2") return "follow u_" + a + "^2 (u_" + a + "^3 in the projection)";
  if (id == "scale_nonlinearity_k3") return "follow u_" + a + "^3";
  if (id == "cross_coupling") return "follow u_" + a + "*u_" + axis.substr(1, 1);
  if (id == "bias_temperature") return "follow the temperature";
  if (id == "scale_temperature") return "follow temperature * u_" + a;
  if (id == "bias_drift") return "grow with time since the start";
  if (id == "hysteresis") return "change sign with the approach direction";
  if (id == "settling_transient") return "decay inside each dwell after arrival";
  if (id == "angle_sensor_error") return "follow harmonics of " + axis + " (turns of the up vector about that axis)";
  return "show structure";
}

std::string num(double v, int prec = 1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%+.*f", prec, v);
  return buf;
}

// The unit parameter that moved most (in its own sigma) between baseline and final fit.
std::string absorbed_words(const FitResult& before, const FitResult& after) {
  int best = -1;
  double best_z = 3;  // below 3 sigma nothing was visibly absorbed
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const auto& b = before.unit[static_cast<std::size_t>(i)];
    const auto& a = after.unit[static_cast<std::size_t>(i)];
    if (!b.value || !a.value || !a.sigma || *a.sigma <= 0) continue;
    const double z = std::abs(*b.value - *a.value) / *a.sigma;
    if (z > best_z) { best_z = z; best = i; }
  }
  if (best < 0) return "";
  const double delta = (*before.unit[static_cast<std::size_t>(best)].value - *after.unit[static_cast<std::size_t>(best)].value) *
                       report_scale(best);
  return std::string(kUnitParameterNames[static_cast<std::size_t>(best)]) + " (" + num(delta) + " " +
         std::string(kUnitParameterUnits[static_cast<std::size_t>(best)]) + ")";
}

std::string parameters_words(const FitResult& fit) {
  std::string s;
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const auto& p = fit.unit[static_cast<std::size_t>(i)];
    if (!p.value) continue;
    if (!s.empty()) s += ", ";
    s += std::string(kUnitParameterNames[static_cast<std::size_t>(i)]) + " " + num(*p.value * report_scale(i)) +
         " +- " + fmt("%.1f", p.sigma.value_or(0) * report_scale(i)) + " " +
         std::string(kUnitParameterUnits[static_cast<std::size_t>(i)]);
  }
  return s;
}

// ---- the diagnosis -----------------------------------------------------------------------

struct Chosen {
  Candidate cand;
  double delta_chi2 = 0;
  double chi2_dof_before = 0, chi2_dof_after = 0;
};

// The chi2 gain a k-parameter term needs for the same false-finding probability as a
// one-parameter term at chi2_1 (P(chi2_2 > t) = exp(-t/2) for two).
double significance_for(double chi2_1, int params) {
  if (params <= 1) return chi2_1;
  return -2.0 * std::log(std::erfc(std::sqrt(chi2_1 / 2.0)));
}

// A term's value and sigma in its report unit; two-parameter terms (the cyclic angle
// error a sin + b cos) are reported as amplitude and phase.
struct TermEstimate {
  double value = 0, sigma = 0, phase_deg = 0;
};

TermEstimate term_estimate(const Candidate& c, const VectorXd& beta, const MatrixXd& cov, Eigen::Index first, double scale) {
  if (c.params == 1) return {beta[first], std::sqrt(cov(first, first)) * scale, 0};
  const double a = beta[first], b = beta[first + 1];
  const double amplitude = std::hypot(a, b);
  const Eigen::Matrix2d C = cov.block(first, first, 2, 2) * scale * scale;
  const double var = amplitude > 0 ? (a * a * C(0, 0) + 2 * a * b * C(0, 1) + b * b * C(1, 1)) / (amplitude * amplitude)
                                   : 0.5 * (C(0, 0) + C(1, 1));
  return {amplitude, std::sqrt(var), std::atan2(b, a) * kRadToDeg};
}

double bic_gain(double delta_chi2, int params, std::size_t n) {
  return delta_chi2 - params * std::log(static_cast<double>(n));
}

FitResult baseline_fit(const std::vector<PositionAverage>& avg, bool full) {
  return full ? fit_full_vector(avg) : fit_invariant_joint(avg);
}

// Angles of one stand axis worth proposing: every 30 deg the axis can reach (normalised to
// its range), plus the ends of a limited range.
std::vector<double> reachable_grid_deg(const AxisRange& range) {
  std::vector<double> out;
  auto add = [&out](double a) {
    for (double b : out)
      if (std::abs(a - b) < 1e-9) return;
    out.push_back(a);
  };
  for (int a = 0; a < 360; a += 30)
    if (const auto n = normalise_angle_deg(a, range)) add(*n);
  if (!range.continuous) {
    add(range.min_deg);
    add(range.max_deg);
  }
  return out;
}

// Candidate poses for proposals: only where the stand can go.
std::vector<ProposedPosition> grid_poses(const StandLimits& limits) {
  std::vector<ProposedPosition> out;
  for (double a1 : reachable_grid_deg(limits.alpha1))
    for (double a2 : reachable_grid_deg(limits.alpha2)) out.push_back({a1, a2, 0, ""});
  return out;
}

// Rows a new pose would add to the design, with sigma `s`.
MatrixXd pose_design_rows(const LinearProblem& lp, const FullDesign* fd, const StandPose& pose, double s) {
  if (lp.full) {
    MatrixXd rows(3, lp.A.cols());
    for (int a = 0; a < 3; ++a) rows.row(a) = full_design_row(*fd, pose, a) / s;
    return rows;
  }
  const Eigen::Matrix<double, 1, 9> reg = invariant_regressor(up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad, pose.mount));
  MatrixXd row = MatrixXd::Zero(1, lp.A.cols());
  for (int j = 0; j < kUnitParameterCount; ++j)
    if (lp.unit_column[static_cast<std::size_t>(j)] >= 0) row(0, lp.unit_column[static_cast<std::size_t>(j)]) = reg[j] / s;
  return row;
}

// Rows (3 full, 1 invariant) x params a candidate would add at a new pose.
MatrixXd pose_candidate_rows(const LinearProblem& lp, const Candidate& c, const PositionContext& p, double s) {
  const MatrixXd e = candidate_effect_g(c, p);
  if (lp.full) return e / s;
  return (p.up.transpose() * e) / s;
}

PositionContext future_context(const StandPose& pose, const std::vector<PositionContext>& ctx, int step) {
  PositionContext p;
  p.up = up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad, pose.mount);
  p.alpha1_deg = pose.alpha1_deg;
  p.alpha2_deg = pose.alpha2_deg;
  p.mount = pose.mount;
  p.t_mid_h = ctx.back().t_mid_h + (step + 1) * 70.0 / 3600.0;
  p.temp_delta_c = ctx.back().temp_delta_c;
  p.approach = step % 2 == 0 ? 1 : -1;
  return p;
}

double median_sigma(const LinearProblem& lp) {
  std::vector<double> s = lp.row_sigma_g;
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

// The part of C's columns that the columns of A cannot explain (least squares on A with
// unit-norm columns). With no column in A nothing is explained: an empty QR must never run.
MatrixXd unexplained_part(const MatrixXd& A, const MatrixXd& C) {
  if (A.cols() == 0 || A.rows() == 0) return C;
  VectorXd norms = A.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < norms.size(); ++j)
    if (norms[j] <= 0) norms[j] = 1;
  const MatrixXd An = A * norms.cwiseInverse().asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(An);
  cod.setThreshold(1e-10);
  return C - An * cod.solve(C);
}

// Fractions of each column (of C) the baseline design A cannot absorb.
VectorXd unabsorbed_fractions(const MatrixXd& A, const MatrixXd& C) {
  const MatrixXd rest = unexplained_part(A, C);
  VectorXd f(C.cols());
  for (Eigen::Index j = 0; j < C.cols(); ++j) {
    const double n = C.col(j).norm();
    f[j] = n > 0 ? rest.col(j).norm() / n : 0.0;
  }
  return f;
}

Eigen::Index total_params(const std::vector<Candidate>& cands) {
  Eigen::Index n = 0;
  for (const Candidate& c : cands) n += c.params;
  return n;
}

// Every candidate's columns side by side.
MatrixXd all_candidate_columns(const std::vector<Candidate>& cands, const LinearProblem& lp,
                               const std::vector<PositionContext>& ctx) {
  MatrixXd C(lp.A.rows(), total_params(cands));
  Eigen::Index j = 0;
  for (const Candidate& c : cands) {
    C.middleCols(j, c.params) = candidate_columns(c, lp, ctx);
    j += c.params;
  }
  return C;
}

// Greedy choice of six reachable grid poses, each the one that most increases how far
// the catalog candidates stand out from the calibration parameters (sum of unabsorbed fractions).
std::vector<ProposedPosition> propose_for_redundancy(const LinearProblem& lp, const FullDesign* fd,
                                                     const std::vector<PositionContext>& ctx,
                                                     const std::vector<Candidate>& cands, Mount mount,
                                                     const StandLimits& limits) {
  const double s = median_sigma(lp);
  MatrixXd A = lp.A;
  MatrixXd C = all_candidate_columns(cands, lp, ctx);
  std::vector<ProposedPosition> chosen;
  for (int step = 0; step < 6; ++step) {
    double best_score = -1;
    ProposedPosition best;
    MatrixXd best_A, best_C;
    for (const ProposedPosition& g : grid_poses(limits)) {
      const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
      const MatrixXd rows = pose_design_rows(lp, fd, pose, s);
      const PositionContext pc = future_context(pose, ctx, step);
      MatrixXd A2(A.rows() + rows.rows(), A.cols());
      A2 << A, rows;
      MatrixXd C2(C.rows() + rows.rows(), C.cols());
      C2.topRows(C.rows()) = C;
      Eigen::Index j = 0;
      for (const Candidate& c : cands) {
        C2.block(C.rows(), j, rows.rows(), c.params) = pose_candidate_rows(lp, c, pc, s);
        j += c.params;
      }
      const double score = unabsorbed_fractions(A2, C2).sum();
      if (score > best_score) { best_score = score; best = g; best_A = A2; best_C = C2; }
    }
    if (best_score < 0) break;  // the stand can reach no grid pose at all
    best.why = "raises the candidates' mean separation from the calibration parameters to " +
               fmt("%.0f", 100.0 * best_score / static_cast<double>(C.cols())) + " %";
    chosen.push_back(best);
    A = best_A;
    C = best_C;
  }
  return chosen;
}

// Poses where the two rival explanations differ most, in sigma of one position's mean.
std::vector<ProposedPosition> propose_discriminating(const LinearProblem& lp, const FullDesign* fd,
                                                     const std::vector<PositionContext>& ctx,
                                                     const std::vector<VectorXd>& chosen_cols,
                                                     const std::vector<Candidate>& chosen_cands,
                                                     const Candidate& c1, const Candidate& c2, Mount mount,
                                                     const StandLimits& limits) {
  const double s = median_sigma(lp);
  auto fit_with = [&](const Candidate& c) {
    std::vector<VectorXd> cols = chosen_cols;
    const MatrixXd extra = candidate_columns(c, lp, ctx);
    for (Eigen::Index j = 0; j < extra.cols(); ++j) cols.push_back(extra.col(j));
    return solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions).beta;
  };
  const VectorXd b1 = fit_with(c1), b2 = fit_with(c2);
  std::vector<ProposedPosition> scored;
  for (ProposedPosition g : grid_poses(limits)) {
    const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
    const PositionContext pc = future_context(pose, ctx, 0);
    const MatrixXd rows = pose_design_rows(lp, fd, pose, s);
    auto predict = [&](const VectorXd& beta, const Candidate& extra) {
      VectorXd pred = rows * beta.head(lp.A.cols());
      Eigen::Index j = lp.A.cols();
      for (const Candidate& c : chosen_cands) {
        pred += pose_candidate_rows(lp, c, pc, s) * beta.segment(j, c.params);
        j += c.params;
      }
      pred += pose_candidate_rows(lp, extra, pc, s) * beta.segment(j, extra.params);
      return pred;
    };
    g.predicted_difference_sigma = (predict(b1, c1) - predict(b2, c2)).norm();
    g.why = "the two explanations predict means " + fmt("%.1f", g.predicted_difference_sigma) + " sigma apart";
    scored.push_back(g);
  }
  std::sort(scored.begin(), scored.end(), [](const ProposedPosition& a, const ProposedPosition& b) {
    return a.predicted_difference_sigma > b.predicted_difference_sigma;
  });
  if (scored.size() > 4) scored.resize(4);
  return scored;
}

void structure_tests(Diagnosis& d, const LinearProblem& lp, const std::vector<PositionContext>& ctx, bool have_temp) {
  const int axes = lp.full ? 3 : 1;
  for (int a = 0; a < axes; ++a) {
    std::vector<std::pair<std::string, std::function<double(const PositionContext&)>>> vars = {
        {"time", [](const PositionContext& p) { return p.t_mid_h; }},
        {"approach", [](const PositionContext& p) { return static_cast<double>(p.approach); }},
        {"angle_u2", [a](const PositionContext& p) { return p.up[a] * p.up[a]; }},
        {"angle_u3", [a](const PositionContext& p) { return p.up[a] * p.up[a] * p.up[a]; }}};
    if (have_temp) vars.push_back({"temperature", [](const PositionContext& p) { return p.temp_delta_c; }});
    for (const auto& [name, f] : vars) {
      std::vector<double> x, y;
      for (std::size_t r = 0; r < lp.row_axis.size(); ++r)
        if (!lp.full || lp.row_axis[r] == a) {
          x.push_back(f(ctx[static_cast<std::size_t>(lp.row_position[r])]));
          y.push_back(lp.y[static_cast<Eigen::Index>(r)]);
        }
      const double mx = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
      double sxy = 0, sxx = 0;
      for (std::size_t i = 0; i < x.size(); ++i) {
        sxy += (x[i] - mx) * y[i];
        sxx += (x[i] - mx) * (x[i] - mx);
      }
      d.structure.push_back({lp.full ? kAxisNames[a] : "L", name, sxx > 0 ? sxy / std::sqrt(sxx) : 0.0});
    }
  }
}

void locate(Diagnosis& d, const LinearProblem& lp, const std::vector<PositionAverage>& avg) {
  const int axes = lp.full ? 3 : 1;
  for (int a = 0; a < axes; ++a) {
    double chi2 = 0;
    int n = 0;
    std::vector<int> flagged;
    double t0 = 1e300, t1 = -1e300;
    for (std::size_t r = 0; r < lp.row_axis.size(); ++r) {
      if (lp.full && lp.row_axis[r] != a) continue;
      const double v = lp.y[static_cast<Eigen::Index>(r)];
      chi2 += v * v;
      ++n;
      if (std::abs(v) > 3) {
        const auto& p = avg[static_cast<std::size_t>(lp.row_position[r])];
        flagged.push_back(p.pos);
        t0 = std::min(t0, p.t_start_s);
        t1 = std::max(t1, p.t_end_s);
      }
    }
    const std::string axis = lp.full ? std::string(kAxisNames[a]) + " output" : "invariant projection";
    std::string s = axis + ": chi2 " + fmt("%.1f", chi2) + " over " + std::to_string(n) + " positions";
    if (!flagged.empty()) {
      s += "; residuals beyond 3 sigma at positions";
      for (int p : flagged) {
        s += ' ';
        s += std::to_string(p);
      }
      s += " (t = " + fmt("%.0f", t0) + " .. " + fmt("%.0f", t1) + " s)";
    } else {
      s += "; no position beyond 3 sigma";
    }
    d.located.push_back(s);
  }
}

}  // namespace

namespace {

// Everything the diagnosis derives from a recording before it tests candidates.
struct Prepared {
  std::vector<PositionAverage> avg;
  bool have_temp = true;
  double temp_ref_c = 0;
  std::vector<PositionContext> ctx;
  bool full = false;
  FullDesign fd;
  FitResult baseline;
  LinearProblem lp;
  LinearFit base;
  std::vector<Candidate> cands;
  std::vector<bool> testable;
  int n_testable = 0;
};

// Degenerate recordings are refused before any fit: no position, a number that is not
// finite, or a dwell whose samples do not vary (its noise, which the check compares
// against, is then unknown).
// Identical samples still give a sample deviation of ~1e-17 g from rounding in the mean;
// no accelerometer's noise comes within nine orders of magnitude of this.
constexpr double kStuckReadingSigma_g = 1e-12;

void require_checkable(const std::vector<PositionAverage>& avg) {
  require_positions(avg, "cannot check the model");
  for (const PositionAverage& p : avg)
    for (int a = 0; a < 3; ++a)
      if (!(p.sigma_g[a] > kStuckReadingSigma_g))
        throw CannotFit("cannot check the model: the " + std::to_string(p.samples) + " samples of position " +
                        std::to_string(p.pos) + " do not vary on axis " + kAxisNames[a] +
                        " (zero variance), so their noise is unknown; are the readings stuck, or quantised "
                        "coarser than the noise?");
}

// The invariant baseline, or why there is none.
FitResult invariant_baseline(const std::vector<PositionAverage>& avg) {
  try {
    return fit_invariant_joint(avg);
  } catch (const CannotFit& e) {
    throw CannotFit("cannot check the model: " + positions_for_unknowns(avg, kUnitParameterCount) +
                    ", and not even the calibration can be fitted (" + e.what() + ")");
  }
}

Prepared prepare(const Recording& rec, const DiagnoseOptions& options) {
  Prepared P;
  P.avg = average_positions(rec);
  require_checkable(P.avg);
  for (const auto& p : P.avg) P.have_temp = P.have_temp && std::isfinite(p.temp_mean_c);
  if (rec.temp_ref_c) P.temp_ref_c = *rec.temp_ref_c;
  else
    for (const auto& s : rec.samples)
      if (std::isfinite(s.temp_c)) { P.temp_ref_c = s.temp_c; break; }
  P.ctx = position_contexts(P.avg, P.temp_ref_c);

  // Baseline: the full vector when it has redundancy, the invariant projection otherwise.
  try {
    P.baseline = fit_full_vector(P.avg);
    P.full = P.baseline.redundancy > 0;
  } catch (const std::exception&) {
    P.full = false;
  }
  if (P.full) P.fd = full_design(P.avg);
  else P.baseline = invariant_baseline(P.avg);
  P.lp = P.full ? full_problem(P.avg, P.baseline, P.fd) : invariant_problem(P.avg, P.baseline);
  P.base = solve_linear(P.lp.A, P.lp.y, P.lp.row_position, P.lp.positions);

  // Which candidates can this programme test at all? Every column of a candidate must
  // keep some of its size after the baseline parameters have absorbed what they can.
  P.cands = catalog_candidates(P.have_temp);
  const VectorXd frac = unabsorbed_fractions(P.lp.A, all_candidate_columns(P.cands, P.lp, P.ctx));
  Eigen::Index j = 0;
  for (const Candidate& c : P.cands) {
    const bool ok = P.base.dof > 0 && frac.segment(j, c.params).minCoeff() > options.min_unabsorbed_fraction;
    P.testable.push_back(ok);
    P.n_testable += ok ? 1 : 0;
    j += c.params;
  }
  return P;
}

// The fitted mounting misalignment about each instrument axis (arcmin, with sigma) from
// the full-vector fit's stand estimates; NaN where the fit has none.
struct MountingEstimate {
  double value_arcmin[3] = {kNaN, kNaN, kNaN};
  double sigma_arcmin[3] = {kNaN, kNaN, kNaN};
  std::string combination[3];
};

MountingEstimate mounting_estimate(const FitResult& fit) {
  MountingEstimate m;
  for (const StandEstimate& e : fit.stand)
    for (int a = 0; a < 3; ++a)
      if (e.name.rfind(std::string("mounting_psi_") + kAxisNames[a], 0) == 0 && e.unit == "arcsec") {
        m.value_arcmin[a] = e.value / 60.0;
        m.sigma_arcmin[a] = e.sigma / 60.0;
        m.combination[a] = e.name;
      }
  return m;
}

// mounting_misalignment_large: the mounting angle about each axis against the fixture
// tolerance. It is a parameter of the full-vector baseline (which models it exactly), so
// this is a test of its size, not a new term: chi2 gain = ((|psi| - tolerance) / sigma)^2.
std::vector<CandidateTest> mounting_tests(const FitResult& fit, double chi2_dof, std::size_t n_rows,
                                          const DiagnoseOptions& options) {
  const MountingEstimate m = mounting_estimate(fit);
  const double scale = std::max(1.0, std::isfinite(chi2_dof) ? std::sqrt(chi2_dof) : 1.0);
  std::vector<CandidateTest> out;
  for (int a = 0; a < 3; ++a) {
    CandidateTest t{"mounting_misalignment_large", kAxisNames[a], "arcmin", true, "", 0, 0, 0, 0, kNaN, 0};
    if (!std::isfinite(m.value_arcmin[a])) {
      t.testable = false;
      t.reason = "the full-vector fit has no estimate of the mounting about this axis";
    } else {
      t.value = m.value_arcmin[a];
      t.sigma = m.sigma_arcmin[a] * scale;
      const double excess = std::abs(t.value) - options.mounting_tolerance_arcmin;
      t.delta_chi2 = excess > 0 && t.sigma > 0 ? (excess / t.sigma) * (excess / t.sigma) : 0.0;
      t.delta_bic = bic_gain(t.delta_chi2, 1, n_rows);
    }
    out.push_back(t);
  }
  return out;
}

// What the paper's invariant method would silently get wrong with this mounting
// (model.md: delta k_i off by -(1 - cos phi)(1 - n_i^2), gamma_ij by 2(1 - cos phi) n_i n_j).
std::string invariant_bias_words(const Vec3& psi_rad) {
  const double phi = psi_rad.norm();
  if (phi <= 0) return "";
  const Vec3 n = psi_rad / phi;
  const double c = 1 - std::cos(phi);
  std::string s;
  for (int i = 0; i < 3; ++i)
    s += std::string(i ? ", " : "") + "dk" + kAxisNames[i] + " " + num(-c * (1 - n[i] * n[i]) / kPpm) + " ppm";
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const char* names[3] = {"gamma12", "gamma13", "gamma23"};
  for (int k = 0; k < 3; ++k)
    s += std::string(", ") + names[k] + " " + num(2 * c * n[pairs[k][0]] * n[pairs[k][1]] * kRadToArcsec) + " arcsec";
  return s;
}

Finding mounting_finding(const CandidateTest& t, const MountingEstimate& m, double chi2_dof, const DiagnoseOptions& options) {
  Finding f{t.effect, t.axis, t.unit, t.value, t.sigma, 0, t.delta_chi2, chi2_dof, chi2_dof, "", "", 0};
  Vec3 psi_rad = Vec3::Zero();
  for (int a = 0; a < 3; ++a)
    if (std::isfinite(m.value_arcmin[a])) psi_rad[a] = m.value_arcmin[a] * kArcminToRad;
  f.explanation = "The horizontal components put the unit's mounting about its " + t.axis + " axis at " + num(t.value, 2) +
                  " +- " + fmt("%.3f", t.sigma) + " arcmin, beyond the fixture tolerance of " +
                  fmt("%.1f", options.mounting_tolerance_arcmin) +
                  " arcmin. Missing physics: a large mounting misalignment. The full-vector fit models it exactly, "
                  "but the invariant method absorbs it silently: with this mounting its results would shift by " +
                  invariant_bias_words(psi_rad) + ". The estimate is the combination " + m.combination[std::string("xyz").find(t.axis[0])] +
                  " (gravity cannot tell the mounting from the antisymmetric non-orthogonality" +
                  std::string(t.axis == "x" ? ", nor, about the inner axis, from its angle zero" : "") + ").";
  return f;
}

}  // namespace

Diagnosis diagnose_recording(const Recording& rec, const DiagnoseOptions& options) {
  Diagnosis d;
  d.source = rec.source;
  const Prepared P = prepare(rec, options);
  const std::vector<PositionAverage>& avg = P.avg;
  const bool have_temp = P.have_temp;
  const double temp_ref_c = P.temp_ref_c;
  const std::vector<PositionContext>& ctx = P.ctx;
  const bool full = P.full;
  const FullDesign& fd = P.fd;
  const LinearProblem& lp = P.lp;
  const LinearFit& base = P.base;
  const std::vector<Candidate>& cands = P.cands;
  const std::vector<bool>& testable = P.testable;
  const int n_testable = P.n_testable;
  d.baseline = P.baseline;
  d.method = full ? "full" : "joint";
  const std::size_t n_rows = static_cast<std::size_t>(lp.y.size());
  d.baseline_p = consistency_p(base.chi2, base.dof);
  structure_tests(d, lp, ctx, have_temp);
  locate(d, lp, avg);

  if (!full)
    d.not_tested.push_back("mounting_misalignment_large: the invariant projection cannot see a mounting misalignment "
                           "(model.md), and this recording has no redundancy for the full-vector fit");
  if (!have_temp)
    d.not_tested.push_back("bias_temperature, scale_temperature: the recording has no temperature column");

  const Mount mount0 = avg.front().mount;
  // Positions the baseline cannot predict from the others (each alone fixes a parameter):
  // there the held-out check is impossible.
  int unpredictable = 0;
  for (Eigen::Index k = 0; k < base.press.size(); ++k) unpredictable += std::isfinite(base.press[k]) ? 0 : 1;
  // The unit's nine parameters come from the gravity projections; with no more positions
  // than that they are fitted exactly and the model cannot be checked (model.md, paper9).
  // A repeated orientation checks repeatability, not the model: count distinct ones.
  const int distinct = distinct_orientations(avg);
  const int projection_redundancy = distinct - kUnitParameterCount;
  if (base.dof <= 0 || projection_redundancy <= 0 || 2 * unpredictable > lp.positions ||
      2 * n_testable < static_cast<int>(cands.size())) {
    d.verdict = "insufficient_redundancy";
    d.final_fit = d.baseline;
    d.final_p = d.baseline_p;
    d.final_chi2_dof = d.baseline.chi2_dof;
    d.proposed_positions = propose_for_redundancy(lp, full ? &fd : nullptr, ctx, cands, mount0, options.limits);
    std::string why;
    if (base.dof <= 0) why = "the fit has no redundancy";
    else if (projection_redundancy <= 0)
      why = positions_for_unknowns(avg, kUnitParameterCount) +
            ": the nine unit parameters rest on only " + std::to_string(distinct) +
            " distinct gravity projections, so they absorb any missing physics exactly";
    else if (2 * unpredictable > lp.positions)
      why = std::to_string(unpredictable) + " of " + std::to_string(lp.positions) +
            " positions cannot be predicted from the others (no held-out check)";
    else
      why = "only " + std::to_string(n_testable) + " of " + std::to_string(cands.size()) +
            " catalog candidates stand out from the calibration parameters";
    d.summary.push_back("The model cannot be checked on this programme: " + why +
                        ". Add the proposed positions and run again.");
    for (std::size_t i = 0; i < cands.size(); ++i) {
      CandidateTest t{cands[i].effect, cands[i].axis, cands[i].unit, static_cast<bool>(testable[i]), "", 0, 0, 0, 0, 0, 0};
      t.params = cands[i].params;
      if (!testable[i]) t.reason = "absorbed by the calibration parameters on this programme";
      d.candidates.push_back(t);
    }
    d.residuals.clear();
    for (std::size_t k = 0; k < avg.size(); ++k) {
      ResidualRow row{avg[k].pos, avg[k].alpha1_cmd_deg, avg[k].alpha2_cmd_deg, ctx[k].t_mid_h * 3600, avg[k].temp_mean_c, avg[k].approach, {}, {}};
      for (std::size_t r = 0; r < n_rows; ++r)
        if (lp.row_position[r] == static_cast<int>(k)) {
          row.before.push_back(lp.y[static_cast<Eigen::Index>(r)]);
          row.after.push_back(lp.y[static_cast<Eigen::Index>(r)]);
        }
      d.residuals.push_back(row);
    }
    d.model = TruthModel{};
    return d;
  }

  // Forward selection: each round tests every candidate against the current model. Terms
  // with more parameters need a larger chi2 gain for the same false-finding probability;
  // candidates are ranked by their gain beyond that need ("excess").
  auto excess = [&options](const CandidateTest& t) {
    return t.testable ? t.delta_chi2 - significance_for(options.significance_chi2, t.params) : -1e300;
  };
  std::vector<Chosen> chosen;
  std::vector<VectorXd> chosen_cols;
  std::vector<Candidate> chosen_cands;
  LinearFit current = base;
  bool ambiguous = false;
  for (int round = 0; round < options.max_terms; ++round) {
    std::vector<std::pair<CandidateTest, std::size_t>> tests;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      CandidateTest t{cands[i].effect, cands[i].axis, cands[i].unit, static_cast<bool>(testable[i]), "", 0, 0, 0, 0, 0, 0};
      t.params = cands[i].params;
      bool already = false;
      for (const Candidate& c : chosen_cands) already = already || (c.effect == cands[i].effect && c.axis == cands[i].axis);
      if (!testable[i]) t.reason = "absorbed by the calibration parameters on this programme";
      if (testable[i] && !already) {
        std::vector<VectorXd> cols = chosen_cols;
        const MatrixXd extra = candidate_columns(cands[i], lp, ctx);
        for (Eigen::Index j = 0; j < extra.cols(); ++j) cols.push_back(extra.col(j));
        const LinearFit f = solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions);
        if (f.rank < current.rank + cands[i].params) {
          t.testable = false;
          t.reason = "collinear with the terms already chosen";
        } else {
          const double scale = std::max(1.0, f.dof > 0 ? std::sqrt(f.chi2 / f.dof) : 1.0);
          const TermEstimate te = term_estimate(cands[i], f.beta, f.cov, f.beta.size() - cands[i].params, scale);
          t.value = te.value;
          t.sigma = te.sigma;
          t.phase_deg = te.phase_deg;
          t.delta_chi2 = current.chi2 - f.chi2;
          t.delta_bic = bic_gain(t.delta_chi2, cands[i].params, n_rows);
          t.press_gain = press_gain(current, f);
        }
      }
      if (!already) tests.push_back({t, i});
    }
    std::stable_sort(tests.begin(), tests.end(), [&excess](const auto& a, const auto& b) { return excess(a.first) > excess(b.first); });
    if (round == 0)
      for (const auto& t : tests) d.candidates.push_back(t.first);
    if (tests.empty()) break;
    const CandidateTest& best = tests.front().first;
    const bool significant = best.testable && excess(best) > 0 && best.delta_bic > 0 && best.press_gain > 0;
    if (!significant) break;
    if (tests.size() > 1) {
      const CandidateTest& rival = tests[1].first;
      if (rival.testable && excess(rival) > 0 && excess(best) - excess(rival) < options.ambiguity_chi2) {
        ambiguous = true;
        d.proposed_positions = propose_discriminating(lp, full ? &fd : nullptr, ctx, chosen_cols, chosen_cands,
                                                      cands[tests.front().second], cands[tests[1].second], mount0,
                                                      options.limits);
        if (!d.proposed_positions.empty() &&
            d.proposed_positions.front().predicted_difference_sigma - d.proposed_positions.back().predicted_difference_sigma < 1) {
          // The rivals differ in time or temperature, not in angle: no pose tells them apart.
          d.proposed_positions.clear();
          d.summary.push_back("No stand position tells these two apart (they differ in time or temperature, not in "
                              "angle); a run whose temperature is not a straight line in time (hold, then ramp) would.");
        }
        d.summary.push_back("Two explanations fit about equally well: " + effect_words(best.effect, best.axis) + " (" +
                            num(best.value) + " " + best.unit + ", chi2 gain " + fmt("%.1f", best.delta_chi2) + ") and " +
                            effect_words(rival.effect, rival.axis) + " (" + num(rival.value) + " " + rival.unit +
                            ", chi2 gain " + fmt("%.1f", rival.delta_chi2) + ")." +
                            (d.proposed_positions.empty() ? "" : " The proposed positions tell them apart."));
        break;
      }
    }
    Chosen c;
    c.cand = cands[tests.front().second];
    c.delta_chi2 = best.delta_chi2;
    c.chi2_dof_before = current.dof > 0 ? current.chi2 / current.dof : kNaN;
    const MatrixXd cols = candidate_columns(c.cand, lp, ctx);
    for (Eigen::Index j = 0; j < cols.cols(); ++j) chosen_cols.push_back(cols.col(j));
    chosen_cands.push_back(c.cand);
    current = solve_linear(with_columns(lp.A, chosen_cols), lp.y, lp.row_position, lp.positions);
    c.chi2_dof_after = current.dof > 0 ? current.chi2 / current.dof : kNaN;
    chosen.push_back(c);
  }

  // Settling transients: inside each dwell, on the raw samples.
  std::vector<SettlingResult> settling;
  for (int a = 0; a < 3; ++a) {
    SettlingResult best = best_settling(rec, avg, a, options.settling_tau_grid_s, options.significance_chi2);
    best.sigma_ug = best.sigma_free_tau_ug;  // tau was estimated from the same samples
    CandidateTest t{"settling_transient", kAxisNames[a], "ug", true, "", best.amplitude_ug, best.sigma_ug,
                    best.delta_chi2, bic_gain(best.delta_chi2, 2, rec.samples.size()), best.press_gain, best.tau_s};
    d.candidates.push_back(t);
    if (best.delta_chi2 > options.significance_chi2 && t.delta_bic > 0 && best.press_gain > 0) settling.push_back(best);
  }

  // Final fit: the averages corrected by the chosen terms, refitted by the same method.
  const int n_terms = static_cast<int>(chosen.size());
  std::vector<PositionAverage> corrected = avg;
  std::vector<TermEstimate> terms;
  int n_term_params = 0;
  {
    const double scale = std::max(1.0, current.dof > 0 ? std::sqrt(current.chi2 / current.dof) : 1.0);
    Eigen::Index col = lp.A.cols();
    for (const Chosen& c : chosen) {
      terms.push_back(term_estimate(c.cand, current.beta, current.cov, col, scale));
      const VectorXd beta = current.beta.segment(col, c.cand.params);
      for (std::size_t k = 0; k < corrected.size(); ++k) corrected[k].mean_g -= candidate_effect_g(c.cand, ctx[k]) * beta;
      col += c.cand.params;
      n_term_params += c.cand.params;
    }
  }
  for (const SettlingResult& s : settling)
    for (std::size_t k = 0; k < corrected.size(); ++k) corrected[k].mean_g[s.axis] -= s.amplitude_ug * kUg * s.mean_shape[k];
  d.final_fit = baseline_fit(corrected, full);
  const int final_dof = d.final_fit.redundancy - n_term_params;
  d.final_chi2_dof = final_dof > 0 ? d.final_fit.chi2 / final_dof : kNaN;
  d.final_p = consistency_p(d.final_fit.chi2, final_dof);
  if (n_terms > 0) {
    // Unit sigmas from the augmented fit: they carry the correlation with the new terms.
    const double scale = std::max(1.0, current.dof > 0 ? std::sqrt(current.chi2 / current.dof) : 1.0);
    for (int i = 0; i < kUnitParameterCount; ++i) {
      const int col = lp.unit_column[static_cast<std::size_t>(i)];
      if (col >= 0 && d.final_fit.unit[static_cast<std::size_t>(i)].value)
        d.final_fit.unit[static_cast<std::size_t>(i)].sigma = std::sqrt(current.cov(col, col)) * scale;
    }
    d.final_fit.redundancy = final_dof;
    d.final_fit.chi2_dof = d.final_chi2_dof;
  }
  // A settling transient's uncertainty moves the bias it had been aliased into.
  for (const SettlingResult& st : settling) {
    auto& bias = d.final_fit.unit[static_cast<std::size_t>(st.axis)];
    if (!bias.value || !bias.sigma) continue;
    const double shape = std::accumulate(st.mean_shape.begin(), st.mean_shape.end(), 0.0) /
                         static_cast<double>(st.mean_shape.size());
    bias.sigma = std::hypot(*bias.sigma, st.sigma_ug * kUg * shape);
  }

  // Large mounting misalignment: the size of the final full-vector fit's mounting angles.
  std::vector<CandidateTest> mounting;
  if (full) mounting = mounting_tests(d.final_fit, d.final_chi2_dof, n_rows, options);
  for (const CandidateTest& t : mounting) d.candidates.push_back(t);

  // Findings, in words.
  const std::string absorbed = absorbed_words(d.baseline, d.final_fit);
  for (int j = 0; j < n_terms; ++j) {
    const Chosen& c = chosen[static_cast<std::size_t>(j)];
    const TermEstimate& te = terms[static_cast<std::size_t>(j)];
    Finding f{c.cand.effect, c.cand.axis, c.cand.unit, te.value, te.sigma, 0, c.delta_chi2,
              c.chi2_dof_before, c.chi2_dof_after, j == 0 ? absorbed : "", "", te.phase_deg};
    const std::string who = c.cand.effect == "angle_sensor_error" ? "the horizontal components"
                            : c.cand.axis.size() == 1            ? "the " + c.cand.axis + " accelerometer"
                                                                 : "the " + c.cand.axis.substr(0, 1) + " accelerometer";
    f.explanation = "Residuals of " + who + " " + signature_words(f.effect, f.axis) + " (chi2/dof " +
                    fmt("%.2f", f.chi2_dof_before) + " -> " + fmt("%.2f", f.chi2_dof_after) + "). Missing physics: " +
                    effect_words(f.effect, f.axis) + ", " + num(f.value) + " +- " + fmt("%.1f", f.sigma) + " " + f.unit;
    if (f.effect == "angle_sensor_error")
      f.explanation += " amplitude (true angle = reading + amplitude * sin(" + f.axis + " " + num(f.phase_deg) + " deg))";
    f.explanation += ".";
    if (!f.absorbed_into.empty()) f.explanation += " It had been absorbed into " + f.absorbed_into + ".";
    d.findings.push_back(f);
  }
  for (const SettlingResult& s : settling) {
    Finding f{"settling_transient", kAxisNames[s.axis], "ug", s.amplitude_ug, s.sigma_ug, s.tau_s, s.delta_chi2,
              kNaN, kNaN, "", "", 0};
    f.explanation = std::string("Raw samples of the ") + kAxisNames[s.axis] + " accelerometer decay inside each dwell after " +
                    "arrival (chi2 gain " + fmt("%.0f", s.delta_chi2) + " on the samples). Missing physics: " +
                    effect_words(f.effect, f.axis) + ", " + num(s.amplitude_ug) + " +- " + fmt("%.1f", s.sigma_ug) +
                    " ug at arrival, tau " + fmt("%.1f", s.tau_s) + " s (grid search, refined). In the per-position means it " +
                    "looks like a bias, which is now corrected.";
    d.findings.push_back(f);
  }
  const MountingEstimate m_est = mounting_estimate(d.final_fit);
  bool large_mounting = false;
  for (const CandidateTest& t : mounting)
    if (t.testable && t.delta_chi2 > options.significance_chi2) {
      d.findings.push_back(mounting_finding(t, m_est, d.final_chi2_dof, options));
      large_mounting = true;
    }
  std::stable_sort(d.findings.begin(), d.findings.end(), [](const Finding& a, const Finding& b) { return a.delta_chi2 > b.delta_chi2; });

  if (ambiguous) d.verdict = "ambiguous";
  else if (d.findings.empty()) d.verdict = d.baseline_p > options.consistency_p ? "consistent" : "unexplained";
  else d.verdict = d.final_p > options.consistency_p ? "explained" : "unexplained";

  // Residual table, before and after.
  const LinearProblem after = full ? full_problem(corrected, d.final_fit, fd) : invariant_problem(corrected, d.final_fit);
  for (std::size_t k = 0; k < avg.size(); ++k) {
    ResidualRow row{avg[k].pos, avg[k].alpha1_cmd_deg, avg[k].alpha2_cmd_deg, ctx[k].t_mid_h * 3600, avg[k].temp_mean_c, avg[k].approach, {}, {}};
    for (std::size_t r = 0; r < n_rows; ++r)
      if (lp.row_position[r] == static_cast<int>(k)) {
        row.before.push_back(lp.y[static_cast<Eigen::Index>(r)]);
        row.after.push_back(after.y[static_cast<Eigen::Index>(r)]);
      }
    d.residuals.push_back(row);
  }

  // Words.
  const std::string base_words = "Baseline (" + std::string(full ? "full-vector" : "invariant") + ") fit: chi2/dof " +
                                 fmt("%.2f", d.baseline.chi2_dof) + ", P = " + fmt("%.3g", d.baseline_p) + ".";
  d.summary.insert(d.summary.begin(), base_words);
  if (d.verdict == "consistent")
    d.summary.push_back("The residuals are consistent with noise and no catalog candidate improves both the fit and the "
                        "held-out prediction: no missing physics found.");
  for (const Finding& f : d.findings) d.summary.push_back(f.explanation);
  if (!d.findings.empty())
    d.summary.push_back("Corrected parameters: " + parameters_words(d.final_fit) + ". Final chi2/dof " +
                        fmt("%.2f", d.final_chi2_dof) + " (P = " + fmt("%.3g", d.final_p) + ").");
  if (d.verdict == "unexplained")
    d.summary.push_back("The residuals are not consistent with noise and the catalog does not explain all of it.");

  // The augmented model, for `standcal simulate --model`.
  TruthModel& m = d.model;
  m = TruthModel{};
  m.g_local_mps2 = rec.g_local_mps2;
  Vec3 pair_sums = Vec3::Zero();
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const double v = d.final_fit.unit[static_cast<std::size_t>(i)].value.value_or(0.0);
    if (i < 3) m.unit.bias_g[i] = v;
    else if (i < 6) m.unit.scale[i - 3] = v;
    else pair_sums[i - 6] = v;
  }
  m.unit.set_gamma_pair_sums_rad(pair_sums);
  if (large_mounting)  // the one stand error that matters beyond first order: the fitted mounting
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(m_est.value_arcmin[a]))
        m.stand.mounting_rad[static_cast<std::size_t>(mount0)][a] = m_est.value_arcmin[a] * kArcminToRad;
  std::vector<double> sig;
  for (const auto& p : avg) sig.push_back(p.sigma_g.mean());
  std::nth_element(sig.begin(), sig.begin() + static_cast<std::ptrdiff_t>(sig.size() / 2), sig.end());
  const double fs = std::isfinite(rec.sample_rate_hz) && rec.sample_rate_hz > 0 ? rec.sample_rate_hz : 100.0;
  m.noise.density_ug_rthz = sig[sig.size() / 2] / kUg / std::sqrt(fs);
  m.temperature.start_c = temp_ref_c;
  m.temperature.noise_c = 0;
  if (have_temp && avg.size() > 1) {
    const double dt_h = ctx.back().t_mid_h - ctx.front().t_mid_h;
    if (dt_h > 0) m.temperature.rate_c_per_h = (ctx.back().temp_delta_c - ctx.front().temp_delta_c) / dt_h;
  }
  for (const Finding& f : d.findings)
    if (f.effect != "mounting_misalignment_large") m.extra_physics.push_back({f.effect, f.axis, f.value, f.tau_s, f.phase_deg});
  return d;
}

std::vector<DiscriminationThreshold> discrimination_thresholds(const Recording& reference, const DiagnoseOptions& options) {
  constexpr double kStandOut = 3;  // sigma
  const Prepared P = prepare(reference, options);
  std::vector<DiscriminationThreshold> out;
  std::vector<MatrixXd> cols;
  for (const Candidate& c : P.cands) cols.push_back(candidate_columns(c, P.lp, P.ctx));
  // Smallest singular value of the part of C that [A, competitor] cannot explain.
  auto unexplained_size = [&P](const MatrixXd& C, const MatrixXd* competitor) {
    MatrixXd M(P.lp.A.rows(), P.lp.A.cols() + (competitor ? competitor->cols() : 0));
    M.leftCols(P.lp.A.cols()) = P.lp.A;
    if (competitor) M.rightCols(competitor->cols()) = *competitor;
    const MatrixXd rest = unexplained_part(M, C);
    return rest.size() == 0 ? 0.0 : Eigen::JacobiSVD<MatrixXd>(rest).singularValues().minCoeff();
  };
  for (std::size_t i = 0; i < P.cands.size(); ++i) {
    if (!P.testable[i]) continue;
    DiscriminationThreshold t{P.cands[i].effect, P.cands[i].axis, P.cands[i].unit, 0, 0, "noise"};
    double smallest = unexplained_size(cols[i], nullptr);
    for (std::size_t k = 0; k < P.cands.size(); ++k) {
      if (k == i || !P.testable[k]) continue;
      const double s = unexplained_size(cols[i], &cols[k]);
      if (s < smallest) {
        smallest = s;
        t.nearest = P.cands[k].effect + " " + P.cands[k].axis;
      }
    }
    t.threshold = smallest > 0 ? kStandOut / smallest : std::numeric_limits<double>::infinity();
    out.push_back(t);
  }
  for (int a = 0; a < 3; ++a)
    for (double tau : options.settling_tau_grid_s) {
      const SettlingResult r = settling_search(reference, P.avg, a, tau);
      // Standing out is a matter of the test at the best tau (sigma with tau known); the
      // reported sigma of a finding is the wider one with tau free.
      out.push_back({"settling_transient", kAxisNames[a], "ug", tau, kStandOut * r.sigma_ug, "noise"});
    }
  if (P.full) {
    const MountingEstimate m = mounting_estimate(P.baseline);
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(m.sigma_arcmin[a]))
        out.push_back({"mounting_misalignment_large", kAxisNames[a], "arcmin", 0,
                       options.mounting_tolerance_arcmin + kStandOut * m.sigma_arcmin[a], "fixture tolerance"});
  }
  return out;
}

Program diagnostic32() {
  std::vector<std::pair<double, double>> a;
  for (double a1 : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0}) a.emplace_back(a1, 0.0);
  for (double a2 : {45.0, 90.0, 135.0, 225.0, 270.0, 315.0}) a.emplace_back(0.0, a2);
  a.emplace_back(45.0, 90.0);
  a.emplace_back(45.0, 270.0);
  a.emplace_back(30.0, 60.0);
  a.emplace_back(330.0, 120.0);
  Program p;
  p.name = "diagnostic32";
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto& [a1, a2] = pass == 0 ? a[i] : a[a.size() - 1 - i];
      ProgramPosition pos;
      pos.alpha1_deg = a1;
      pos.alpha2_deg = a2;
      p.positions.push_back(pos);
    }
  return p;
}

Vec3 identifiable_mounting_rad(const TruthModel& truth) {
  // The fit's mounting rotation R' = R(theta_a) R(psi) C2(d_alpha2): the antisymmetric part
  // of Gamma acts as a rotation right after the mounting (I + Gamma_a = I - [theta_a x]),
  // and the inner-axis zero is a rotation about x right before it (model.md's chain).
  const Mat3& g = truth.unit.gamma_rad;
  const Vec3 theta_a(0.5 * (g(1, 2) - g(2, 1)), -0.5 * (g(0, 2) - g(2, 0)), 0.5 * (g(0, 1) - g(1, 0)));
  const Mat3 R = rotation_exp(theta_a) * rotation_exp(truth.stand.mounting_rad[0]) * C2(truth.stand.alpha2_offset_rad);
  const Eigen::AngleAxisd aa(Mat3(R.transpose()));  // rotation_exp(psi) = exp(-[psi x])
  return aa.angle() * aa.axis();
}

nlohmann::json diagnose_to_json(const Diagnosis& d) {
  using nlohmann::json;
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json findings = json::array();
  for (const Finding& f : d.findings) {
    json j = {{"effect", f.effect}, {"axis", f.axis}, {"value", f.value}, {"sigma", f.sigma}, {"unit", f.unit},
              {"chi2_dof_after", number(f.chi2_dof_after)}, {"delta_chi2", f.delta_chi2},
              {"explanation", f.explanation}};
    if (f.effect == "settling_transient") j["tau_s"] = f.tau_s;
    if (f.effect == "angle_sensor_error") j["phase_deg"] = f.phase_deg;
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
      j["heldout_gain"] = number(c.press_gain);  // null where it does not apply (mounting size test)
      if (c.params > 1) j["params"] = c.params;
      if (c.effect == "angle_sensor_error") j["phase_deg"] = c.phase_deg;
    } else {
      j["reason"] = c.reason;
    }
    candidates.push_back(j);
  }
  json structure = json::array();
  for (const StructureTest& s : d.structure) structure.push_back({{"axis", s.axis}, {"against", s.against}, {"z", s.z}});
  json proposed = json::array();
  for (const ProposedPosition& p : d.proposed_positions) {
    json j = {{"alpha1_deg", p.alpha1_deg}, {"alpha2_deg", p.alpha2_deg}, {"why", p.why}};
    if (p.predicted_difference_sigma > 0) j["predicted_difference_sigma"] = p.predicted_difference_sigma;
    proposed.push_back(j);
  }
  return {{"verdict", d.verdict},
          {"method", d.method},
          {"baseline", {{"chi2_dof", number(d.baseline.chi2_dof)}, {"p_value", d.baseline_p},
                        {"residual_rms_ug", d.baseline.residual_rms_g / kUg}}},
          {"findings", findings},
          {"final", {{"chi2_dof", number(d.final_chi2_dof)}, {"p_value", d.final_p},
                     {"residual_rms_ug", d.final_fit.residual_rms_g / kUg}, {"parameters", fit_to_json(d.final_fit)}}},
          {"proposed_positions", proposed},
          {"structure_tests", structure},
          {"located", d.located},
          {"candidates", candidates},
          {"not_tested", d.not_tested},
          {"summary", d.summary},
          {"model", truth_to_json(d.model)}};
}

}  // namespace standcal
