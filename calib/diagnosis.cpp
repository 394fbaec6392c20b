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
#include "calib/invariant_estimator.hpp"
#include "calib/report.hpp"

namespace standcal {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kAxisNames[3] = {"x", "y", "z"};

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// What the diagnosis knows about one position besides its mean.
struct PositionContext {
  Vec3 up = Vec3::Zero();
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
};

Vec3 candidate_effect_g(const Candidate& c, const PositionContext& p) {
  Vec3 e = Vec3::Zero();
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
  e[i] = v * 1e-6;
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
  return out;
}

VectorXd candidate_column(const Candidate& c, const LinearProblem& lp, const std::vector<PositionContext>& ctx) {
  VectorXd col(lp.y.size());
  for (Eigen::Index r = 0; r < col.size(); ++r) {
    const PositionContext& p = ctx[static_cast<std::size_t>(lp.row_position[static_cast<std::size_t>(r)])];
    const Vec3 e = candidate_effect_g(c, p);
    const int axis = lp.row_axis[static_cast<std::size_t>(r)];
    const double value = axis >= 0 ? e[axis] : p.up.dot(e);
    col[r] = value / lp.row_sigma_g[static_cast<std::size_t>(r)];
  }
  return col;
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

LinearFit solve_linear(const MatrixXd& X, const VectorXd& y, const std::vector<int>& row_position, int positions) {
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
  std::vector<double> mean_shape;  // per position: dwell mean of exp(-(t - t_arrive) / tau)
};

// Per axis and tau: within-dwell residuals (sample - position mean) regressed on the
// de-meaned exp(-(t - t_arrive)/tau) together with a de-meaned linear trend (which a
// bias drift leaves inside a dwell, and which must not count as a transient).
SettlingResult settling_search(const Recording& rec, const std::vector<PositionAverage>& avg, int axis, double tau_s) {
  SettlingResult res;
  res.axis = axis;
  res.tau_s = tau_s;
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < avg.size(); ++k) index[avg[k].pos] = k;
  const std::size_t npos = avg.size();
  std::vector<double> sum_e(npos, 0), sum_t(npos, 0), count(npos, 0);
  const double g = rec.g_local_mps2;
  for (const RecordingSample& s : rec.samples) {
    const std::size_t k = index.at(s.pos);
    sum_e[k] += std::exp(-(s.t_s - avg[k].t_arrive_s) / tau_s);
    sum_t[k] += s.t_s;
    count[k] += 1;
  }
  res.mean_shape.resize(npos);
  // Normal equations of [shape, trend] per position, accumulated (for leave-one-out).
  std::vector<Eigen::Matrix2d> N(npos, Eigen::Matrix2d::Zero());
  std::vector<Eigen::Vector2d> b(npos, Eigen::Vector2d::Zero());
  std::vector<double> rr(npos, 0);
  for (const RecordingSample& s : rec.samples) {
    const std::size_t k = index.at(s.pos);
    const double sig = std::max(avg[k].sigma_g[axis], 1e-9);
    const double e = std::exp(-(s.t_s - avg[k].t_arrive_s) / tau_s) - sum_e[k] / count[k];
    const double t = (s.t_s - sum_t[k] / count[k]) / 60.0;
    const double r = (s.f_mps2[axis] / g - avg[k].mean_g[axis]) / sig;
    const Eigen::Vector2d x(e / sig, t / sig);
    N[k] += x * x.transpose();
    b[k] += x * r;
    rr[k] += r * r;
  }
  Eigen::Matrix2d Nt = Eigen::Matrix2d::Zero();
  Eigen::Vector2d bt = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < npos; ++k) {
    Nt += N[k];
    bt += b[k];
    res.mean_shape[k] = sum_e[k] / count[k];
  }
  if (std::abs(Nt.determinant()) < 1e-30 || Nt(0, 0) <= 0) return res;
  // chi2 gain of the transient over the trend alone.
  const Eigen::Vector2d beta = Nt.ldlt().solve(bt);
  const double gain_both = beta.dot(bt);
  const double gain_trend = Nt(1, 1) > 0 ? bt[1] * bt[1] / Nt(1, 1) : 0;
  res.delta_chi2 = gain_both - gain_trend;
  const Eigen::Matrix2d cov = Nt.inverse();
  res.amplitude_ug = beta[0] / kUg;
  res.sigma_ug = std::sqrt(cov(0, 0)) / kUg;
  // Leave one position out: predict its within-dwell residuals from the others.
  for (std::size_t k = 0; k < npos; ++k) {
    const Eigen::Matrix2d Nk = Nt - N[k];
    if (std::abs(Nk.determinant()) < 1e-30 || Nk(1, 1) <= 0) continue;
    const Eigen::Vector2d bk = Nk.ldlt().solve(bt - b[k]);
    const double trend_only = (bt[1] - b[k][1]) / Nk(1, 1);
    const double with = rr[k] - 2 * bk.dot(b[k]) + bk.dot(N[k] * bk);
    const double without = rr[k] - 2 * trend_only * b[k][1] + trend_only * trend_only * N[k](1, 1);
    res.press_gain += without - with;
  }
  return res;
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
  VectorXd column;
  double delta_chi2 = 0;
  double chi2_dof_before = 0, chi2_dof_after = 0;
};

double bic_gain(double delta_chi2, int params, std::size_t n) {
  return delta_chi2 - params * std::log(static_cast<double>(n));
}

FitResult baseline_fit(const std::vector<PositionAverage>& avg, bool full) {
  return full ? fit_full_vector(avg) : fit_invariant_joint(avg);
}

std::vector<ProposedPosition> grid_poses() {
  std::vector<ProposedPosition> out;
  for (int a1 = 0; a1 < 360; a1 += 30)
    for (int a2 = 0; a2 < 360; a2 += 30) out.push_back({static_cast<double>(a1), static_cast<double>(a2), 0, ""});
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
  MatrixXd row(1, lp.A.cols());
  for (int j = 0; j < kUnitParameterCount; ++j)
    if (lp.unit_column[static_cast<std::size_t>(j)] >= 0) row(0, lp.unit_column[static_cast<std::size_t>(j)]) = reg[j] / s;
  return row;
}

VectorXd pose_candidate_rows(const LinearProblem& lp, const Candidate& c, const PositionContext& p, double s) {
  const Vec3 e = candidate_effect_g(c, p);
  if (lp.full) return e / s;
  VectorXd v(1);
  v[0] = p.up.dot(e) / s;
  return v;
}

PositionContext future_context(const StandPose& pose, const std::vector<PositionContext>& ctx, int step) {
  PositionContext p;
  p.up = up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad, pose.mount);
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

// Fractions of each column (of C) the baseline design A cannot absorb.
VectorXd unabsorbed_fractions(const MatrixXd& A, const MatrixXd& C) {
  VectorXd norms = A.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < norms.size(); ++j)
    if (norms[j] <= 0) norms[j] = 1;
  const MatrixXd An = A * norms.cwiseInverse().asDiagonal();
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(An);
  cod.setThreshold(1e-10);
  const MatrixXd rest = C - An * cod.solve(C);
  VectorXd f(C.cols());
  for (Eigen::Index j = 0; j < C.cols(); ++j) {
    const double n = C.col(j).norm();
    f[j] = n > 0 ? rest.col(j).norm() / n : 0.0;
  }
  return f;
}

// Greedy choice of six grid poses, each the one that most increases how far the catalog
// candidates stand out from the calibration parameters (sum of unabsorbed fractions).
std::vector<ProposedPosition> propose_for_redundancy(const LinearProblem& lp, const FullDesign* fd,
                                                     const std::vector<PositionContext>& ctx,
                                                     const std::vector<Candidate>& cands, Mount mount) {
  const double s = median_sigma(lp);
  MatrixXd A = lp.A;
  MatrixXd C(lp.A.rows(), static_cast<Eigen::Index>(cands.size()));
  for (std::size_t i = 0; i < cands.size(); ++i) C.col(static_cast<Eigen::Index>(i)) = candidate_column(cands[i], lp, ctx);
  std::vector<ProposedPosition> chosen;
  for (int step = 0; step < 6; ++step) {
    double best_score = -1;
    ProposedPosition best;
    MatrixXd best_A, best_C;
    for (const ProposedPosition& g : grid_poses()) {
      const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
      const MatrixXd rows = pose_design_rows(lp, fd, pose, s);
      const PositionContext pc = future_context(pose, ctx, step);
      MatrixXd A2(A.rows() + rows.rows(), A.cols());
      A2 << A, rows;
      MatrixXd C2(C.rows() + rows.rows(), C.cols());
      C2.topRows(C.rows()) = C;
      for (std::size_t i = 0; i < cands.size(); ++i)
        C2.block(C.rows(), static_cast<Eigen::Index>(i), rows.rows(), 1) = pose_candidate_rows(lp, cands[i], pc, s);
      const double score = unabsorbed_fractions(A2, C2).sum();
      if (score > best_score) { best_score = score; best = g; best_A = A2; best_C = C2; }
    }
    best.why = "raises the candidates' mean separation from the calibration parameters to " +
               fmt("%.0f", 100.0 * best_score / static_cast<double>(cands.size())) + " %";
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
                                                     const Candidate& c1, const Candidate& c2, Mount mount) {
  const double s = median_sigma(lp);
  auto fit_with = [&](const Candidate& c) {
    std::vector<VectorXd> cols = chosen_cols;
    cols.push_back(candidate_column(c, lp, ctx));
    return solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions).beta;
  };
  const VectorXd b1 = fit_with(c1), b2 = fit_with(c2);
  std::vector<ProposedPosition> scored;
  for (ProposedPosition g : grid_poses()) {
    const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
    const PositionContext pc = future_context(pose, ctx, 0);
    const MatrixXd rows = pose_design_rows(lp, fd, pose, s);
    auto predict = [&](const VectorXd& beta, const Candidate& extra) {
      VectorXd pred = rows * beta.head(lp.A.cols());
      for (std::size_t j = 0; j < chosen_cands.size(); ++j)
        pred += pose_candidate_rows(lp, chosen_cands[j], pc, s) * beta[lp.A.cols() + static_cast<Eigen::Index>(j)];
      pred += pose_candidate_rows(lp, extra, pc, s) * beta[beta.size() - 1];
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

Diagnosis diagnose_recording(const Recording& rec, const DiagnoseOptions& options) {
  Diagnosis d;
  d.source = rec.source;
  const std::vector<PositionAverage> avg = average_positions(rec);
  bool have_temp = true;
  for (const auto& p : avg) have_temp = have_temp && std::isfinite(p.temp_mean_c);
  double temp_ref_c = 0;
  if (rec.temp_ref_c) temp_ref_c = *rec.temp_ref_c;
  else
    for (const auto& s : rec.samples)
      if (std::isfinite(s.temp_c)) { temp_ref_c = s.temp_c; break; }
  const std::vector<PositionContext> ctx = position_contexts(avg, temp_ref_c);

  // Baseline: the full vector when it has redundancy, the invariant projection otherwise.
  FullDesign fd;
  bool full = false;
  try {
    d.baseline = fit_full_vector(avg);
    full = d.baseline.redundancy > 0;
  } catch (const std::exception&) {
    full = false;
  }
  if (full) fd = full_design(avg);
  else d.baseline = fit_invariant_joint(avg);
  d.method = full ? "full" : "joint";
  const LinearProblem lp = full ? full_problem(avg, d.baseline, fd) : invariant_problem(avg, d.baseline);
  const std::size_t n_rows = static_cast<std::size_t>(lp.y.size());
  const LinearFit base = solve_linear(lp.A, lp.y, lp.row_position, lp.positions);
  d.baseline_p = consistency_p(base.chi2, base.dof);
  structure_tests(d, lp, ctx, have_temp);
  locate(d, lp, avg);

  const std::vector<Candidate> cands = catalog_candidates(have_temp);
  d.not_tested.push_back("mounting_misalignment_large: the baseline already fits the mounting misalignment with exact "
                         "rotations (full vector); in the invariant projection it is invisible by construction");
  d.not_tested.push_back("angle_sensor_error: not implemented in this version of the diagnosis");
  if (!have_temp)
    d.not_tested.push_back("bias_temperature, scale_temperature: the recording has no temperature column");

  // Which candidates can this programme test at all?
  std::vector<bool> testable(cands.size(), false);
  int n_testable = 0;
  {
    MatrixXd C(lp.A.rows(), static_cast<Eigen::Index>(cands.size()));
    for (std::size_t i = 0; i < cands.size(); ++i) C.col(static_cast<Eigen::Index>(i)) = candidate_column(cands[i], lp, ctx);
    const VectorXd frac = unabsorbed_fractions(lp.A, C);
    for (std::size_t i = 0; i < cands.size(); ++i) {
      testable[i] = base.dof > 0 && frac[static_cast<Eigen::Index>(i)] > options.min_unabsorbed_fraction;
      n_testable += testable[i] ? 1 : 0;
    }
  }
  const Mount mount0 = avg.front().mount;
  // Positions the baseline cannot predict from the others (each alone fixes a parameter):
  // there the held-out check is impossible.
  int unpredictable = 0;
  for (Eigen::Index k = 0; k < base.press.size(); ++k) unpredictable += std::isfinite(base.press[k]) ? 0 : 1;
  // The unit's nine parameters come from the gravity projections; with no more positions
  // than that they are fitted exactly and the model cannot be checked (model.md, paper9).
  const int projection_redundancy = static_cast<int>(avg.size()) - kUnitParameterCount;
  if (base.dof <= 0 || projection_redundancy <= 0 || 2 * unpredictable > lp.positions ||
      2 * n_testable < static_cast<int>(cands.size())) {
    d.verdict = "insufficient_redundancy";
    d.final_fit = d.baseline;
    d.final_p = d.baseline_p;
    d.final_chi2_dof = d.baseline.chi2_dof;
    d.proposed_positions = propose_for_redundancy(lp, full ? &fd : nullptr, ctx, cands, mount0);
    std::string why;
    if (base.dof <= 0) why = "the fit has no redundancy";
    else if (projection_redundancy <= 0)
      why = "the nine unit parameters rest on only " + std::to_string(avg.size()) +
            " gravity projections, so they absorb any missing physics exactly";
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

  // Forward selection: each round tests every candidate against the current model.
  std::vector<Chosen> chosen;
  std::vector<VectorXd> chosen_cols;
  std::vector<Candidate> chosen_cands;
  LinearFit current = base;
  bool ambiguous = false;
  for (int round = 0; round < options.max_terms; ++round) {
    std::vector<std::pair<CandidateTest, std::size_t>> tests;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      CandidateTest t{cands[i].effect, cands[i].axis, cands[i].unit, static_cast<bool>(testable[i]), "", 0, 0, 0, 0, 0, 0};
      bool already = false;
      for (const Candidate& c : chosen_cands) already = already || (c.effect == cands[i].effect && c.axis == cands[i].axis);
      if (!testable[i]) t.reason = "absorbed by the calibration parameters on this programme";
      if (testable[i] && !already) {
        std::vector<VectorXd> cols = chosen_cols;
        cols.push_back(candidate_column(cands[i], lp, ctx));
        const LinearFit f = solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions);
        if (f.rank <= current.rank) {
          t.testable = false;
          t.reason = "collinear with the terms already chosen";
        } else {
          const Eigen::Index j = f.beta.size() - 1;
          const double scale = std::max(1.0, f.dof > 0 ? std::sqrt(f.chi2 / f.dof) : 1.0);
          t.value = f.beta[j];
          t.sigma = std::sqrt(f.cov(j, j)) * scale;
          t.delta_chi2 = current.chi2 - f.chi2;
          t.delta_bic = bic_gain(t.delta_chi2, 1, n_rows);
          t.press_gain = press_gain(current, f);
        }
      }
      if (!already) tests.push_back({t, i});
    }
    std::sort(tests.begin(), tests.end(), [](const auto& a, const auto& b) { return a.first.delta_chi2 > b.first.delta_chi2; });
    if (round == 0)
      for (const auto& t : tests) d.candidates.push_back(t.first);
    if (tests.empty()) break;
    const CandidateTest& best = tests.front().first;
    const bool significant = best.testable && best.delta_chi2 > options.significance_chi2 && best.delta_bic > 0 && best.press_gain > 0;
    if (!significant) break;
    if (tests.size() > 1) {
      const CandidateTest& rival = tests[1].first;
      if (rival.testable && rival.delta_chi2 > options.significance_chi2 &&
          best.delta_chi2 - rival.delta_chi2 < options.ambiguity_chi2) {
        ambiguous = true;
        d.proposed_positions = propose_discriminating(lp, full ? &fd : nullptr, ctx, chosen_cols, chosen_cands,
                                                      cands[tests.front().second], cands[tests[1].second], mount0);
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
                            ", chi2 gain " + fmt("%.1f", rival.delta_chi2) + "). The proposed positions tell them apart.");
        break;
      }
    }
    Chosen c;
    c.cand = cands[tests.front().second];
    c.column = candidate_column(c.cand, lp, ctx);
    c.delta_chi2 = best.delta_chi2;
    c.chi2_dof_before = current.dof > 0 ? current.chi2 / current.dof : kNaN;
    chosen_cols.push_back(c.column);
    chosen_cands.push_back(c.cand);
    current = solve_linear(with_columns(lp.A, chosen_cols), lp.y, lp.row_position, lp.positions);
    c.chi2_dof_after = current.dof > 0 ? current.chi2 / current.dof : kNaN;
    chosen.push_back(c);
  }

  // Settling transients: inside each dwell, on the raw samples.
  std::vector<SettlingResult> settling;
  for (int a = 0; a < 3; ++a) {
    SettlingResult best;
    for (double tau : options.settling_tau_grid_s) {
      const SettlingResult r = settling_search(rec, avg, a, tau);
      if (r.delta_chi2 > best.delta_chi2) best = r;
    }
    CandidateTest t{"settling_transient", kAxisNames[a], "ug", true, "", best.amplitude_ug, best.sigma_ug,
                    best.delta_chi2, bic_gain(best.delta_chi2, 2, rec.samples.size()), best.press_gain, best.tau_s};
    d.candidates.push_back(t);
    if (best.delta_chi2 > options.significance_chi2 && t.delta_bic > 0 && best.press_gain > 0) settling.push_back(best);
  }

  // Final fit: the averages corrected by the chosen terms, refitted by the same method.
  const int n_terms = static_cast<int>(chosen.size());
  std::vector<PositionAverage> corrected = avg;
  VectorXd term_values(n_terms), term_sigmas(n_terms);
  if (n_terms > 0) {
    const double scale = std::max(1.0, current.dof > 0 ? std::sqrt(current.chi2 / current.dof) : 1.0);
    for (int j = 0; j < n_terms; ++j) {
      const Eigen::Index col = lp.A.cols() + j;
      term_values[j] = current.beta[col];
      term_sigmas[j] = std::sqrt(current.cov(col, col)) * scale;
      for (std::size_t k = 0; k < corrected.size(); ++k)
        corrected[k].mean_g -= candidate_effect_g(chosen[static_cast<std::size_t>(j)].cand, ctx[k]) * term_values[j];
    }
  }
  for (const SettlingResult& s : settling)
    for (std::size_t k = 0; k < corrected.size(); ++k) corrected[k].mean_g[s.axis] -= s.amplitude_ug * kUg * s.mean_shape[k];
  d.final_fit = baseline_fit(corrected, full);
  const int final_dof = d.final_fit.redundancy - n_terms;
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

  // Findings, in words.
  const std::string absorbed = absorbed_words(d.baseline, d.final_fit);
  for (int j = 0; j < n_terms; ++j) {
    const Chosen& c = chosen[static_cast<std::size_t>(j)];
    Finding f{c.cand.effect, c.cand.axis, c.cand.unit, term_values[j], term_sigmas[j], 0, c.delta_chi2,
              c.chi2_dof_before, c.chi2_dof_after, j == 0 ? absorbed : "", ""};
    const std::string who = c.cand.axis.size() == 1 ? "the " + c.cand.axis + " accelerometer" : "the " + c.cand.axis.substr(0, 1) + " accelerometer";
    f.explanation = "Residuals of " + who + " " + signature_words(f.effect, f.axis) + " (chi2/dof " +
                    fmt("%.2f", f.chi2_dof_before) + " -> " + fmt("%.2f", f.chi2_dof_after) + "). Missing physics: " +
                    effect_words(f.effect, f.axis) + ", " + num(f.value) + " +- " + fmt("%.1f", f.sigma) + " " + f.unit + ".";
    if (!f.absorbed_into.empty()) f.explanation += " It had been absorbed into " + f.absorbed_into + ".";
    d.findings.push_back(f);
  }
  for (const SettlingResult& s : settling) {
    Finding f{"settling_transient", kAxisNames[s.axis], "ug", s.amplitude_ug, s.sigma_ug, s.tau_s, s.delta_chi2,
              kNaN, kNaN, "", ""};
    f.explanation = std::string("Raw samples of the ") + kAxisNames[s.axis] + " accelerometer decay inside each dwell after " +
                    "arrival (chi2 gain " + fmt("%.0f", s.delta_chi2) + " on the samples). Missing physics: " +
                    effect_words(f.effect, f.axis) + ", " + num(s.amplitude_ug) + " +- " + fmt("%.1f", s.sigma_ug) +
                    " ug at arrival, tau " + fmt("%.0f", s.tau_s) + " s (grid search). In the per-position means it " +
                    "looks like a bias, which is now corrected.";
    d.findings.push_back(f);
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
  for (const Finding& f : d.findings) m.extra_physics.push_back({f.effect, f.axis, f.value, f.tau_s});
  return d;
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
      j["heldout_gain"] = c.press_gain;
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

namespace {

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

std::string residual_cells(const std::vector<double>& v) {
  std::string s;
  for (double x : v) {
    const bool hot = std::abs(x) > 3;
    s += std::string("<td") + (hot ? " class=\"hot\"" : "") + ">" + fmt("%+.2f", x) + "</td>";
  }
  return s;
}

}  // namespace

std::string diagnose_to_html(const Diagnosis& d) {
  std::string h = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>standcal diagnosis</title>"
                  "<style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #999;"
                  "padding:2px 6px;text-align:right}.hot{background:#f99}</style></head><body>\n";
  h += "<h1>Model-mismatch diagnosis: " + html_escape(d.source) + "</h1>\n";
  h += "<p><b>Verdict: " + html_escape(d.verdict) + "</b> (method: " + html_escape(d.method) + ")</p>\n<ul>";
  for (const std::string& s : d.summary) h += "<li>" + html_escape(s) + "</li>";
  h += "</ul>\n<h2>Where the mismatch is</h2><ul>";
  for (const std::string& s : d.located) h += "<li>" + html_escape(s) + "</li>";
  h += "</ul>\n<h2>Findings</h2><table><tr><th>effect</th><th>axis</th><th>value</th><th>sigma</th><th>unit</th>"
       "<th>chi2 gain</th><th>chi2/dof after</th></tr>";
  for (const Finding& f : d.findings)
    h += "<tr><td>" + f.effect + "</td><td>" + f.axis + "</td><td>" + fmt("%+.2f", f.value) + "</td><td>" +
         fmt("%.2f", f.sigma) + "</td><td>" + f.unit + "</td><td>" + fmt("%.1f", f.delta_chi2) + "</td><td>" +
         fmt("%.2f", f.chi2_dof_after) + "</td></tr>";
  h += "</table>\n<h2>Normalised residuals per position (residual / standard error), before and after</h2>"
       "<p>Cells beyond 3 sigma are highlighted. No plotting library is installed on this system, so the residuals "
       "against angle, time and temperature are given as this table (columns alpha, t, T, approach) instead of plots.</p>"
       "<table><tr><th>pos</th><th>alpha1</th><th>alpha2</th><th>t_s</th><th>T_c</th><th>d</th><th colspan=3>before</th>"
       "<th colspan=3>after</th></tr>";
  for (const ResidualRow& r : d.residuals)
    h += "<tr><td>" + std::to_string(r.pos) + "</td><td>" + fmt("%.1f", r.alpha1_deg) + "</td><td>" +
         fmt("%.1f", r.alpha2_deg) + "</td><td>" + fmt("%.0f", r.t_mid_s) + "</td><td>" + fmt("%.2f", r.temp_c) +
         "</td><td>" + std::to_string(r.approach) + "</td>" + residual_cells(r.before) + residual_cells(r.after) + "</tr>";
  h += "</table>\n<h2>Structure tests (baseline residual trend, sigma units)</h2><table><tr><th>axis</th><th>against</th><th>z</th></tr>";
  for (const StructureTest& s : d.structure)
    h += "<tr><td>" + s.axis + "</td><td>" + s.against + "</td><td" + (std::abs(s.z) > 3 ? " class=\"hot\"" : "") + ">" +
         fmt("%+.2f", s.z) + "</td></tr>";
  h += "</table>\n<h2>Catalog candidates (first round, against the baseline)</h2><table><tr><th>effect</th><th>axis</th>"
       "<th>value</th><th>sigma</th><th>unit</th><th>chi2 gain</th><th>BIC gain</th><th>held-out gain</th></tr>";
  for (const CandidateTest& c : d.candidates) {
    if (!c.testable) {
      h += "<tr><td>" + c.effect + "</td><td>" + c.axis + "</td><td colspan=6>" + html_escape(c.reason) + "</td></tr>";
      continue;
    }
    h += "<tr><td>" + c.effect + "</td><td>" + c.axis + "</td><td>" + fmt("%+.2f", c.value) + "</td><td>" +
         fmt("%.2f", c.sigma) + "</td><td>" + c.unit + "</td><td>" + fmt("%.1f", c.delta_chi2) + "</td><td>" +
         fmt("%.1f", c.delta_bic) + "</td><td>" + fmt("%.1f", c.press_gain) + "</td></tr>";
  }
  h += "</table>\n";
  if (!d.proposed_positions.empty()) {
    h += "<h2>Proposed positions</h2><table><tr><th>alpha1</th><th>alpha2</th><th>why</th></tr>";
    for (const ProposedPosition& p : d.proposed_positions)
      h += "<tr><td>" + fmt("%.0f", p.alpha1_deg) + "</td><td>" + fmt("%.0f", p.alpha2_deg) + "</td><td>" + html_escape(p.why) + "</td></tr>";
    h += "</table>\n";
  }
  h += "<h2>Not tested</h2><ul>";
  for (const std::string& s : d.not_tested) h += "<li>" + html_escape(s) + "</li>";
  h += "</ul></body></html>\n";
  return h;
}

}  // namespace standcal
