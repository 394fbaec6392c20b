#include "calib/noise_model.hpp"

#include "calib/distributions.hpp"
#include "calib/golden_section.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>

namespace standcal {

using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

std::vector<std::size_t> time_order(const std::vector<NoiseRow>& rows) {
  std::vector<std::size_t> order(rows.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&rows](std::size_t a, std::size_t b) { return rows[a].t_s < rows[b].t_s; });
  return order;
}

}  // namespace

NoiseRow noise_row(const PositionAverage& position, const Vec3& projection, double sigma_g) {
  return {position.mid_time_s(), projection, sigma_g, position.span_s()};
}

std::vector<NoiseRow> full_vector_noise_rows(const std::vector<PositionAverage>& positions,
                                             double sigma_floor_g) {
  std::vector<NoiseRow> rows;
  rows.reserve(3 * positions.size());
  for (const PositionAverage& p : positions)
    for (int a = 0; a < 3; ++a)
      rows.push_back(noise_row(p, Vec3::Unit(a), std::max(p.standard_error_g[a], sigma_floor_g)));
  return rows;
}

std::vector<NoiseRow> invariant_noise_rows(const std::vector<PositionAverage>& positions,
                                           const std::vector<double>& sigma_g) {
  std::vector<NoiseRow> rows;
  rows.reserve(positions.size());
  for (std::size_t k = 0; k < positions.size(); ++k)
    rows.push_back(noise_row(positions[k], positions[k].up(), sigma_g[k]));
  return rows;
}

namespace {

// Of a window x = length / tau long: (1 - e^-x) / x, how much of the process at its start
// its mean sees (and, by symmetry, at its end).
double window_through(double x) { return x < 1e-8 ? 1.0 : -std::expm1(-x) / x; }

// 2 (x - 1 + e^-x) / x^2, the variance of the window's mean in units of q^2.
double window_mean_variance(double x) {
  if (x < 1e-4) return 1 - x / 3 + x * x / 12;
  return 2 * (x + std::expm1(-x)) / (x * x);
}

// The variance of the window's mean not explained by the process at its start:
// window_mean_variance - window_through^2 = (2 (x - 1 + e^-x) - (1 - e^-x)^2) / x^2.
double window_mean_innovation(double x) {
  if (x < 1e-3) return x * (2.0 / 3 - x * (0.5 - 7.0 / 30 * x));
  const double e = -std::expm1(-x);
  return (2 * (x - e) - e * e) / (x * x);
}

double window_start_s(const NoiseRow& r) { return r.t_s - 0.5 * r.window_s; }
double window_end_s(const NoiseRow& r) { return r.t_s + 0.5 * r.window_s; }

bool same_window(const NoiseRow& a, const NoiseRow& b) {
  return a.t_s == b.t_s && a.window_s == b.window_s;
}

}  // namespace

double gauss_markov_window_correlation(double a_start_s, double a_length_s, double b_start_s,
                                       double b_length_s, double tau_s) {
  const bool a_first = a_start_s <= b_start_s;
  const double first_start = a_first ? a_start_s : b_start_s;
  const double first_length = a_first ? a_length_s : b_length_s;
  const double second_start = a_first ? b_start_s : a_start_s;
  const double second_length = a_first ? b_length_s : a_length_s;
  const double x_first = first_length / tau_s, x_second = second_length / tau_s;
  if (first_start == second_start && first_length == second_length)
    return window_mean_variance(x_first);
  const double gap_s = std::max(0.0, second_start - (first_start + first_length));
  return window_through(x_first) * window_through(x_second) * std::exp(-gap_s / tau_s);
}

MatrixXd row_covariance(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise) {
  const auto n = static_cast<Eigen::Index>(rows.size());
  MatrixXd c = MatrixXd::Zero(n, n);
  const Vec3 q2 = noise.q_g.cwiseAbs2();
  for (Eigen::Index r = 0; r < n; ++r) {
    const NoiseRow& a = rows[static_cast<std::size_t>(r)];
    c(r, r) = a.sigma_g * a.sigma_g;
    if (noise.white() || noise.tau_s <= 0) continue;
    for (Eigen::Index s = 0; s < n; ++s) {
      const NoiseRow& b = rows[static_cast<std::size_t>(s)];
      c(r, s) += a.projection.cwiseProduct(b.projection).dot(q2) *
                 gauss_markov_window_correlation(window_start_s(a), a.window_s, window_start_s(b),
                                                 b.window_s, noise.tau_s);
    }
  }
  return c;
}

// The filter's state is the wander b at the end of the last window and the wander's mean M
// over the current window, per axis: [b; M]. Between windows b decays as e^(-gap / tau);
// across a window of x = length / tau, from b at its start,
//   b_end = e^-x b + w,  M = (1 - e^-x) / x b + v,
// with var w = q^2 (1 - e^-2x), cov(w, v) = q^2 (1 - e^-x)^2 / x, var v = q^2
// window_mean_innovation(x) (the process's integral over the window); a window of length 0 is
// the instant M = b.
MatrixXd decorrelate(const std::vector<NoiseRow>& rows, const GaussMarkovNoise& noise,
                     const MatrixXd& whitened, double* log_det_out) {
  double log_det = 0;
  if (noise.white() || noise.tau_s <= 0) {
    if (log_det_out) *log_det_out = 0;
    return whitened;
  }
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  const Eigen::Index k = whitened.cols();
  MatrixXd out(whitened.rows(), k);
  const Eigen::Array3d q2 = noise.q_g.array().square();
  Matrix6d P = Matrix6d::Zero();
  P.topLeftCorner<3, 3>() = q2.matrix().asDiagonal();  // the wander starts stationary
  MatrixXd state = MatrixXd::Zero(6, k);               // its estimate, one per column
  // Allocated once, and the products below written without temporaries: the REML search
  // calls this some 300 times a fit (docs/performance.md).
  Eigen::RowVectorXd innovation(k);
  const NoiseRow* window = nullptr;  // the window the last row was a mean over
  for (std::size_t r : time_order(rows)) {
    const NoiseRow& row = rows[r];
    if (!window || !same_window(*window, row)) {
      if (window) {  // from the last window's end to this one's start: b(t + dt) = a b(t) + w
        const double gap_s = std::max(0.0, window_start_s(row) - window_end_s(*window));
        const double a = std::exp(-gap_s / noise.tau_s);  // the same on every axis
        state.topRows<3>() *= a;
        P.topLeftCorner<3, 3>() *= a;  // a P a, in the order of diag(a) P diag(a)
        P.topLeftCorner<3, 3>() *= a;
        const double a2 = a * a;  // its own statement: not fused into 1 - a a (FMA targets)
        P.topLeftCorner<3, 3>().diagonal().array() += q2 * (1 - a2);
      }
      const double x = row.window_s / noise.tau_s;
      const double decay = std::exp(-x), through = window_through(x);
      const double one_minus_decay = -std::expm1(-x);
      const Eigen::Matrix3d Pb = P.topLeftCorner<3, 3>();
      state.bottomRows<3>() = through * state.topRows<3>();
      state.topRows<3>() *= decay;
      P.topLeftCorner<3, 3>() = decay * decay * Pb;
      P.topRightCorner<3, 3>() = decay * through * Pb;
      P.bottomLeftCorner<3, 3>() = decay * through * Pb;
      P.bottomRightCorner<3, 3>() = through * through * Pb;
      P.topLeftCorner<3, 3>().diagonal().array() += q2 * (1 - decay * decay);
      const Eigen::Array3d cross = q2 * (x > 0 ? one_minus_decay * one_minus_decay / x : 0.0);
      P.topRightCorner<3, 3>().diagonal().array() += cross;
      P.bottomLeftCorner<3, 3>().diagonal().array() += cross;
      P.bottomRightCorner<3, 3>().diagonal().array() += q2 * window_mean_innovation(x);
      window = &row;
    }
    const Eigen::RowVector3d H = row.projection.transpose() / row.sigma_g;  // whitened units
    innovation.noalias() = whitened.row(static_cast<Eigen::Index>(r)) - H * state.bottomRows<3>();
    const Eigen::Matrix<double, 6, 1> PHt = P.rightCols<3>() * H.transpose();
    const double S = H * PHt.tail<3>() + 1.0;
    const Eigen::Matrix<double, 6, 1> K = PHt / S;
    state.noalias() += K * innovation;
    P -= K * S * K.transpose();
    out.row(static_cast<Eigen::Index>(r)) = innovation / std::sqrt(S);
    log_det += std::log(S);
  }
  if (log_det_out) *log_det_out = log_det;
  return out;
}

namespace {

// Restricted log-likelihood (up to a constant) of the model's residual under `noise`.
class RestrictedLikelihood {
 public:
  RestrictedLikelihood(const std::vector<NoiseRow>& rows, const MatrixXd& X, const VectorXd& y)
      : rows_(rows) {
    data_.resize(y.size(), X.cols() + 1);
    data_.col(0) = y;
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      const double norm = X.col(j).norm();  // unit columns: the design mixes scales of 1e6
      data_.col(j + 1) = norm > 0 ? VectorXd(X.col(j) / norm) : VectorXd(X.col(j));
    }
    Eigen::ColPivHouseholderQR<MatrixXd> qr(data_.rightCols(X.cols()));
    qr.setThreshold(1e-9);
    rank_ = qr.rank();  // held fixed, so every noise model is compared on the same model
  }

  double operator()(const GaussMarkovNoise& noise) const {
    double log_det = 0;
    const MatrixXd z = decorrelate(rows_, noise, data_, &log_det);
    const VectorXd y = z.col(0);
    const MatrixXd X = z.rightCols(z.cols() - 1);
    double log_det_xtx = 0, rss = y.squaredNorm();
    if (rank_ > 0) {
      Eigen::ColPivHouseholderQR<MatrixXd> qr(X);
      const MatrixXd R = qr.matrixR().topLeftCorner(rank_, rank_).triangularView<Eigen::Upper>();
      for (Eigen::Index i = 0; i < rank_; ++i) log_det_xtx += 2 * std::log(std::abs(R(i, i)));
      const VectorXd qty = qr.householderQ().adjoint() * y;
      rss = qty.tail(qty.size() - rank_).squaredNorm();
    }
    return -0.5 * (log_det + log_det_xtx + rss);
  }

 private:
  const std::vector<NoiseRow>& rows_;
  MatrixXd data_;
  Eigen::Index rank_ = 0;
};

double median_row_sigma(const std::vector<NoiseRow>& rows) {
  std::vector<double> s;
  for (const NoiseRow& r : rows) s.push_back(r.sigma_g);
  std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2), s.end());
  return s[s.size() / 2];
}

// A noise model whose restricted log-likelihood log_l is within plausible_lr (2 delta log L)
// of the best's, kept with its likelihood relative to the best's.
void keep_if_plausible(std::vector<PlausibleNoise>& out, const GaussMarkovNoise& noise,
                       double log_l, double best_log_l, double plausible_lr) {
  if (2 * (best_log_l - log_l) <= plausible_lr)
    out.push_back({noise, std::exp(log_l - best_log_l)});
}

// The estimator's range of wander sizes, in log10 of q over the median row's sigma: q from 3 %
// to 30x a row's sigma.
constexpr double kLogQLo = -1.5, kLogQHi = 1.5;

struct WanderFit {
  GaussMarkovNoise noise;
  double log_l = -1e300;
  int q_parameters = 0;                          // the common q, and each axis that left it
  std::array<bool, 3> shared{true, true, true};  // the axes still on the common q
};

// For one tau: a common q for the three axes first (one dimension, robust), then each
// axis on its own, each compared with no wander on that axis. An axis leaves the common q
// only when that beats it by axis_lr in 2 delta log L (axis_quieter_lr for a q below the
// common one, or none): taking every small gain let an axis's q come out low by chance, and
// its bias sigma with it (the full-vector fit's biases at z-variance 1.9-2.5 under a wander
// of 1x the dwell error, 1.0 with the test; docs/calibration.md).
WanderFit best_for_tau(const RestrictedLikelihood& L, double tau_s, double sigma_ref,
                       const NoiseEstimateOptions& options) {
  constexpr int kEvaluations = 14;
  auto with_q = [&](const Vec3& q) { return L(GaussMarkovNoise{q, tau_s}); };
  // The best q shared by the axes in `shared`, the others held as in `q`.
  auto best_shared = [&](const Vec3& q, const std::array<bool, 3>& shared) {
    auto set = [&](double u) {
      Vec3 out = q;
      for (int a = 0; a < 3; ++a)
        if (shared[static_cast<std::size_t>(a)]) out[a] = sigma_ref * std::pow(10, u);
      return out;
    };
    return set(golden_section_max([&](double u) { return with_q(set(u)); }, kLogQLo, kLogQHi,
                                  kEvaluations, std::greater<double>())
                   .first);
  };
  WanderFit best{{Vec3::Zero(), tau_s}, 0, 0};
  best.log_l = L(best.noise);
  std::array<bool, 3> shared{true, true, true};
  const auto take_if_better = [&](const Vec3& q, int q_parameters) {
    if (const double l = with_q(q); l > best.log_l) best = {{q, tau_s}, l, q_parameters, shared};
  };
  take_if_better(best_shared(Vec3::Zero(), shared), 1);
  const bool common = best.q_parameters == 1;
  for (int axis = 0; axis < 3; ++axis) {
    std::array<bool, 3> alone{};
    alone[static_cast<std::size_t>(axis)] = true;
    const double before = best.log_l;  // the axis as it is, nested in its own q or none
    for (const Vec3& q : {best_shared(best.noise.q_g, alone), [&] {
                            Vec3 none = best.noise.q_g;
                            none[axis] = 0;
                            return none;
                          }()})
      if (const double l = with_q(q);
          l > best.log_l &&
          2 * (l - before) >
              (q[axis] < best.noise.q_g[axis] ? options.axis_quieter_lr : options.axis_lr)) {
        const bool first_departure = shared[static_cast<std::size_t>(axis)];
        shared[static_cast<std::size_t>(axis)] = false;
        best = {{q, tau_s}, l, best.q_parameters + (first_departure ? 1 : 0), shared};
      }
  }
  // An axis that left took its share of the common q with it: the axes still sharing it get
  // their own best common value (x and y would otherwise keep a compromise with a quiet z).
  const int still_shared = static_cast<int>(std::count(shared.begin(), shared.end(), true));
  if (common && best.q_parameters > 1 && still_shared > 0)
    take_if_better(best_shared(best.noise.q_g, shared), best.q_parameters);
  return best;
}

// The wander's free scales at the optimum: the axes still sharing the common q (those with a
// wander), and each axis that left it with its own. An axis left with none has no scale.
std::vector<Vec3> free_scales(const WanderFit& fit) {
  std::vector<Vec3> out;
  Vec3 common = Vec3::Zero();
  for (int a = 0; a < 3; ++a) {
    if (fit.noise.q_g[a] <= 0) continue;
    if (fit.shared[static_cast<std::size_t>(a)]) {
      common[a] = 1;
    } else {
      out.push_back(Vec3::Unit(a));
    }
  }
  if (!common.isZero()) out.insert(out.begin(), common);
  return out;
}

// noise with the q of `axes` multiplied by s, u = log s^2.
GaussMarkovNoise scaled_wander(const GaussMarkovNoise& noise, const Vec3& axes, double u) {
  GaussMarkovNoise n = noise;
  for (int a = 0; a < 3; ++a)
    if (axes[a] != 0) n.q_g[a] *= std::exp(u / 2);
  return n;
}

// -d^2 log L / du_k du_l at the optimum, u_k = log s_k^2 for the q of scale k's axes
// multiplied by s_k (central differences). A scale the likelihood does not curve in (its
// diagonal not positive: the optimum at the search's edge) is left out, its size taken
// as known, as a single scale's was.
WanderScales wander_scales(const RestrictedLikelihood& L, const WanderFit& fit) {
  constexpr double kH = 0.25;
  auto at = [&](const std::vector<std::pair<const Vec3*, double>>& steps) {
    GaussMarkovNoise n = fit.noise;
    for (const auto& [axes, u] : steps) n = scaled_wander(n, *axes, u);
    return L(n);
  };
  WanderScales out;
  std::vector<double> diagonal;
  for (const Vec3& axes : free_scales(fit)) {
    const double d = -(at({{&axes, kH}}) - 2 * fit.log_l + at({{&axes, -kH}})) / (kH * kH);
    if (d <= 0) continue;
    out.axes.push_back(axes);
    diagonal.push_back(d);
  }
  const auto k = static_cast<Eigen::Index>(out.axes.size());
  out.information = MatrixXd::Zero(k, k);
  for (Eigen::Index i = 0; i < k; ++i) {
    out.information(i, i) = diagonal[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < i; ++j) {
      const Vec3 *a = &out.axes[static_cast<std::size_t>(i)],
                 *b = &out.axes[static_cast<std::size_t>(j)];
      const double mixed = (at({{a, kH}, {b, kH}}) - at({{a, kH}, {b, -kH}}) -
                            at({{a, -kH}, {b, kH}}) + at({{a, -kH}, {b, -kH}})) /
                           (4 * kH * kH);
      out.information(i, j) = out.information(j, i) = -mixed;
    }
  }
  return out;
}

std::string wander_words(const NoiseEstimate& e) {
  char b[256];
  std::snprintf(
      b, sizeof b,
      "Gauss-Markov bias wander fitted to the per-position residuals by restricted maximum "
      "likelihood (Kalman-filter innovations, tau grid); 2 delta log L = %.1f against white noise "
      "(threshold %.1f)",
      e.lr, e.lr_threshold);
  return b;
}

}  // namespace

double restricted_log_likelihood(const std::vector<NoiseRow>& rows, const MatrixXd& X,
                                 const VectorXd& y, const GaussMarkovNoise& noise) {
  return RestrictedLikelihood(rows, X, y)(noise);
}

std::vector<PlausibleNoise> plausible_wander_sizes(const std::vector<NoiseRow>& rows,
                                                   const MatrixXd& X, const VectorXd& y,
                                                   const NoiseEstimateOptions& options,
                                                   const std::optional<WanderCurves>& curves_ug) {
  constexpr double kStep = 0.25;  // in log10 q: 13 sizes over the range
  if (rows.size() < 3 || static_cast<Eigen::Index>(rows.size()) <= X.cols()) return {};
  const RestrictedLikelihood L(rows, X, y);
  const double sigma_ref = median_row_sigma(rows);
  // The rows' log-likelihood, and the curves' where given (a deviance: -2 log L).
  const auto log_l_of = [&](const GaussMarkovNoise& n) {
    if (!curves_ug) return L(n);
    return L(n) - 0.5 * curves_ug->deviance(n.q_g.maxCoeff() / kUg, n.tau_s);
  };
  std::vector<std::pair<GaussMarkovNoise, double>> all{{GaussMarkovNoise{}, log_l_of({})}};
  for (const double tau : options.tau_grid_s)
    for (double u = kLogQLo; u <= kLogQHi + 1e-9; u += kStep) {
      const GaussMarkovNoise n{Vec3::Constant(sigma_ref * std::pow(10, u)), tau};
      all.emplace_back(n, log_l_of(n));
    }
  double best = -std::numeric_limits<double>::infinity();
  for (const auto& [n, log_l] : all) best = std::max(best, log_l);
  std::vector<PlausibleNoise> out;
  for (const auto& [n, log_l] : all) keep_if_plausible(out, n, log_l, best, options.plausible_lr);
  return out;
}

NoiseEstimate estimate_bias_wander(const std::vector<NoiseRow>& rows, const MatrixXd& X,
                                   const VectorXd& y, const NoiseEstimateOptions& options) {
  NoiseEstimate out;
  if (rows.size() < 3 || static_cast<Eigen::Index>(rows.size()) <= X.cols()) {
    out.how = "not estimated: too few rows";
    return out;
  }
  out.lr_threshold = options.lr_threshold;
  const RestrictedLikelihood L(rows, X, y);
  const double white_log_l = L(GaussMarkovNoise{});
  const double sigma_ref = median_row_sigma(rows);
  WanderFit best{{}, white_log_l};
  std::vector<WanderFit> per_tau;
  for (const double tau : options.tau_grid_s) {
    per_tau.push_back(best_for_tau(L, tau, sigma_ref, options));
    if (per_tau.back().log_l > best.log_l) best = per_tau.back();
  }
  for (const WanderFit& c : per_tau)
    if (!c.noise.white())
      keep_if_plausible(out.plausible, c.noise, c.log_l, best.log_l, options.plausible_lr);
  out.best = best.noise;
  if (!best.noise.white())
    out.parameters = best.q_parameters + (options.tau_grid_s.size() > 1 ? 1 : 0);
  out.lr = 2 * (best.log_l - white_log_l);
  out.significant = !best.noise.white() && out.lr > options.lr_threshold;
  if (out.significant) out.noise = best.noise;
  out.how = wander_words(out);
  if (!best.noise.white()) out.scales = wander_scales(L, best);
  return out;
}

namespace {

// nu_j = 2 var_j^2 / (g_j' I^-1 g_j) (Welch-Satterthwaite), var = variances(noise), with g_j
// the gradient of var_j in the scales' u = log s^2 and I their information; infinite where
// the wander is known or white. A scale the run pins poorly (I's small eigenvalues, as for
// an axis's own q from its few rows) is what makes nu small.
VectorXd parameter_variance_dof(const std::function<VectorXd(const GaussMarkovNoise&)>& variances,
                                const VectorXd& var, const GaussMarkovNoise& noise,
                                const WanderScales& scales) {
  VectorXd nu = VectorXd::Constant(var.size(), std::numeric_limits<double>::infinity());
  if (noise.white() || scales.empty()) return nu;
  constexpr double kH = 0.2;  // step in u = log s^2
  MatrixXd slope(var.size(), static_cast<Eigen::Index>(scales.axes.size()));
  for (std::size_t k = 0; k < scales.axes.size(); ++k)
    slope.col(static_cast<Eigen::Index>(k)) =
        (variances(scaled_wander(noise, scales.axes[k], kH)) -
         variances(scaled_wander(noise, scales.axes[k], -kH))) /
        (2 * kH);
  // I^-1. Each diagonal is positive (wander_scales keeps only such scales); a cross term
  // too large for I to be positive definite is differencing noise, or a departed axis's q not
  // re-optimised with the common one: the scales are then taken one by one.
  const Eigen::LDLT<MatrixXd> ldlt(scales.information);
  const bool positive_definite =
      ldlt.info() == Eigen::Success && ldlt.isPositive() && ldlt.vectorD().minCoeff() > 0;
  const MatrixXd u_covariance =
      positive_definite ? MatrixXd(ldlt.solve(MatrixXd::Identity(slope.cols(), slope.cols())))
                        : MatrixXd(scales.information.diagonal().cwiseInverse().asDiagonal());
  for (Eigen::Index j = 0; j < var.size(); ++j) {
    const double var_of_var = slope.row(j) * u_covariance * slope.row(j).transpose();
    if (var_of_var > 0) nu[j] = 2 * var[j] * var[j] / var_of_var;
  }
  return nu;
}

// The parameters' variances averaged over `plausible` (not empty), each weighted by its
// likelihood.
VectorXd likelihood_weighted_variance(
    const std::function<VectorXd(const GaussMarkovNoise&)>& variances,
    const std::vector<PlausibleNoise>& plausible) {
  VectorXd sum = VectorXd::Zero(0);
  double weights = 0;
  for (const PlausibleNoise& p : plausible) {
    const VectorXd v = p.weight * variances(p.noise);
    sum = sum.size() ? VectorXd(sum + v) : v;
    weights += p.weight;
  }
  return sum / weights;
}

// Each parameter's largest variance over `plausible` (not empty).
VectorXd largest_variance(const std::function<VectorXd(const GaussMarkovNoise&)>& variances,
                          const std::vector<PlausibleNoise>& plausible) {
  VectorXd out = variances(plausible.front().noise);
  for (std::size_t i = 1; i < plausible.size(); ++i)
    out = out.cwiseMax(variances(plausible[i].noise));
  return out;
}

}  // namespace

// sqrt(nu / (nu - 2)), the standard deviation of Student's t, so that a sigma with nu
// effective degrees of freedom has z-variance 1; capped at nu = 2.5 where it runs away.
double student_t_inflation(double nu) {
  constexpr double kMinNu = 2.5;
  if (!std::isfinite(nu)) return 1.0;
  const double n = std::max(nu, kMinNu);
  return std::sqrt(n / (n - 2));
}

SigmaWidening widen_for_estimated_noise(
    const std::function<Eigen::VectorXd(const GaussMarkovNoise&)>& variances,
    const FitNoiseChoice& choice) {
  const VectorXd at_best = variances(choice.noise);
  SigmaWidening w{VectorXd::Ones(at_best.size()),
                  parameter_variance_dof(variances, at_best, choice.noise, choice.scales)};
  // Averaged over the correlation times the run allows, each weighted by its likelihood; or,
  // above a floor, the largest over them (FitNoiseChoice::sigmas_at_slowest_tau).
  const VectorXd averaged = choice.plausible.empty() ? at_best
                            : choice.sigmas_at_slowest_tau
                                ? largest_variance(variances, choice.plausible)
                                : likelihood_weighted_variance(variances, choice.plausible);
  for (Eigen::Index j = 0; j < at_best.size(); ++j)
    if (at_best[j] > 0)
      w.factor[j] =
          std::sqrt(std::max(averaged[j], at_best[j]) / at_best[j]) * student_t_inflation(w.dof[j]);
  // Averaged over the wander's sizes the run allows: at least that, and that alone where the
  // recording's Allan curves weighed them too (FitNoiseChoice::sizes_weigh_curves). The
  // Student-t widening rests on the rows' likelihood alone, whose curvature at a wander
  // weighted for below the bar of a finding is slight (nu near its floor, the sigma doubled);
  // the curves pin the size where the rows cannot, and the average over both is the whole of
  // what is known of it. The averaged variances are each wander's GLS one, not that of the
  // estimate as weighted (a sandwich), which they understate: floored at the variance at the
  // wander weighted with, the runs weighted for one below the bar under white noise went from
  // 0.72-0.98 in z-variance to 0.22-0.31 (bench/noise --runs 300 --warmup-hours 1,
  // docs/calibration.md), so no floor.
  if (!choice.plausible_sizes.empty()) {
    const VectorXd over_sizes = likelihood_weighted_variance(variances, choice.plausible_sizes);
    for (Eigen::Index j = 0; j < at_best.size(); ++j) {
      if (!(at_best[j] > 0)) continue;
      const double over_sizes_factor = std::sqrt(over_sizes[j] / at_best[j]);
      w.factor[j] =
          choice.sizes_weigh_curves ? over_sizes_factor : std::max(w.factor[j], over_sizes_factor);
    }
  }
  return w;
}

// Whether the correlation time was given (specified with the wander, or known: one value or a
// range) and, where it was estimated or given as a range, the times of the grid the run
// allows (`plausible`: what the sigmas were averaged over).
void set_tau_provenance(NoiseFinding& n, const std::vector<PlausibleNoise>& plausible,
                        const std::optional<KnownTau>& known) {
  n.tau_given = known.has_value() || n.source == "specified";
  n.tau_given_min_s = n.tau_given_max_s = 0;
  n.tau_given_open_above = known && known->open_above;
  if (known && known->range()) {
    n.tau_given_min_s = known->min_s;
    n.tau_given_max_s = known->max_s;
  }
  n.tau_plausible_min_s = n.tau_plausible_max_s = 0;
  if (n.tau_given && n.tau_given_max_s == 0) return;
  for (const PlausibleNoise& p : plausible) {
    const double t = p.noise.tau_s;
    n.tau_plausible_min_s = n.tau_plausible_min_s > 0 ? std::min(n.tau_plausible_min_s, t) : t;
    n.tau_plausible_max_s = std::max(n.tau_plausible_max_s, t);
  }
}

NoiseFinding noise_finding(const NoiseEstimate& e, const std::vector<PositionAverage>& avg,
                           const std::optional<KnownTau>& known_tau) {
  NoiseFinding n;
  n.lr = e.lr;
  n.lr_threshold = e.lr_threshold;
  n.how = e.how;
  if (e.noise.white()) return n;
  n.model = "gauss_markov";
  n.source = e.significant ? "estimated" : "specified";
  set_tau_provenance(n, e.plausible, known_tau);
  n.bias_instability = e.significant;
  n.tau_s = e.noise.tau_s;
  std::vector<double> spans_s;
  for (const PositionAverage& p : avg) spans_s.push_back(p.span_s());
  std::nth_element(spans_s.begin(),
                   spans_s.begin() + static_cast<std::ptrdiff_t>(spans_s.size() / 2),
                   spans_s.end());
  // The wander's share of one dwell mean's error: its variance over the median dwell.
  const double wander_share = window_mean_variance(spans_s[spans_s.size() / 2] / e.noise.tau_s);
  for (int a = 0; a < 3; ++a) {
    std::vector<double> se;
    for (const PositionAverage& p : avg) se.push_back(p.standard_error_g[a]);
    std::nth_element(se.begin(), se.begin() + static_cast<std::ptrdiff_t>(se.size() / 2), se.end());
    const double sigma = se[se.size() / 2], q = e.noise.q_g[a];
    n.wander_ug[a] = q / kUg;
    n.wander_axes_specified[static_cast<std::size_t>(a)] =
        e.axes_specified[static_cast<std::size_t>(a)];
    n.allan_peak_ug[a] = gauss_markov_allan_peak(q, e.noise.tau_s).deviation / kUg;
    n.understated_by[a] = sigma > 0 ? std::sqrt(1 + wander_share * q * q / (sigma * sigma)) : 1.0;
  }
  return n;
}

GaussMarkovNoise specified_at_known_tau(const FitNoiseOptions& options) {
  GaussMarkovNoise specified = options.specified;
  if (!specified.white() && options.known_tau && options.known_tau->range())
    specified.tau_s = options.known_tau->centre_s();
  return specified;
}

namespace {

// The largest wander of `sizes` (plausible_wander_sizes), in ug.
double largest_wander_ug(const std::vector<PlausibleNoise>& sizes) {
  double largest_g = 0;
  for (const PlausibleNoise& p : sizes) largest_g = std::max(largest_g, p.noise.q_g.maxCoeff());
  return largest_g / kUg;
}

// What the sigmas of a fit averaged over the wander's sizes allow for, in noise.how: at least
// that average, or with the recording's Allan curves that average alone.
// `curves_from`: whose Allan curves weighed them (FitNoiseOptions::wander_curves_from), or
// empty.
std::string allowed_sizes_words(double largest_ug, double plausible_lr,
                                const std::string& curves_from) {
  const char* curves = curves_from.empty() ? ""
                       : curves_from == kWanderFromStaticRecording
                           ? " and the unit's static recording"
                           : " and its Allan curves";
  char b[300];
  std::snprintf(b, sizeof b,
                "; the sigmas %s their average over the wanders this run%s cannot exclude, up to "
                "%.3g ug (2 delta log L <= %g), each by its likelihood",
                curves_from.empty() ? "at least" : "are", curves, largest_ug, plausible_lr);
  return b;
}

// A run that departs from the specified wander because its own is larger on some axis was
// judged at the laxer bar (specified_exceeded_p), which says nothing of an axis where its own
// is smaller: that axis keeps the specified q, in the wander weighted with and at every
// plausible correlation time. A q taken too small makes that axis's bias sigma too small: a
// norm fit's z wander of 0.4 ug where 31.6 was simulated (and specified) left its bias 9.7
// sigma off (bench/noise --warmup-hours 2, 10x, seed 238). Returns whether any axis was kept.
bool keep_specified_where_smaller(NoiseEstimate& e, const Vec3& specified_q_g) {
  for (int a = 0; a < 3; ++a)
    e.axes_specified[static_cast<std::size_t>(a)] = e.noise.q_g[a] < specified_q_g[a];
  const bool any = std::ranges::any_of(e.axes_specified, [](bool kept) { return kept; });
  e.noise.q_g = e.noise.q_g.cwiseMax(specified_q_g);
  for (PlausibleNoise& p : e.plausible) p.noise.q_g = p.noise.q_g.cwiseMax(specified_q_g);
  return any;
}

}  // namespace

// (A size given without its time is no unit's wander: the default time is no one's, so the
// callers ask only with known_tau.)
bool run_agrees_with_specified(const std::vector<NoiseRow>& rows, const MatrixXd& X,
                               const VectorXd& y, const FitNoiseOptions& options,
                               NoiseEstimate& e) {
  const GaussMarkovNoise specified = specified_at_known_tau(options);
  const RestrictedLikelihood L(rows, X, y);
  const double lr = std::max(0.0, 2 * (L(e.best) - L(specified)));
  const double p = chi_square_upper_tail(lr, std::max(1, e.parameters));
  const bool larger = (e.best.q_g.array() > specified.q_g.array()).any();
  const bool agrees = p >= (larger ? options.specified_exceeded_p : options.specified_departure_p);
  char words[160];
  std::snprintf(words, sizeof words, " (2 delta log L = %.1f against it, P = %.2g)", lr, p);
  e.how += agrees ? "; consistent with the specified bias instability" + std::string(words) +
                        ", which is weighted with"
                  : "; departs from the specified bias instability" + std::string(words) +
                        ", so this run's own is weighted with";
  if (!agrees && larger && keep_specified_where_smaller(e, specified.q_g))
    e.how += ", the specified one on the axes where the run's is smaller";
  return agrees;
}

namespace {

// The choice with options.known_tau as given. Its only caller, choose_fit_noise, refits without
// a floor where the choice is no finding, so a floor's tau_given_open_above needs setting only
// on a Gauss-Markov finding (set_tau_provenance).
FitNoiseChoice choose_fit_noise_as_given(const std::vector<NoiseRow>& rows, const MatrixXd& X,
                                         const VectorXd& y, const FitNoiseOptions& options,
                                         const std::vector<PositionAverage>& positions) {
  using Mode = FitNoiseOptions::Mode;
  NoiseEstimate e;
  bool weighted_below_bar = false, specified_over_range = false, agrees_with_specified = false;
  std::vector<PlausibleNoise> plausible_sizes;
  double allowed_ug = 0;  // the largest of plausible_sizes
  // A floor under the correlation time (KnownTau::open_above):
  // FitNoiseChoice::sigmas_at_slowest_tau.
  const bool above_floor = options.known_tau && options.known_tau->open_above;
  // The specified wander; where its correlation time is known only as a range, weighted at the
  // range's log-middle and the biases' variance averaged over the range, each time alike (no
  // run's likelihood weighs them: the run did not show the wander, or was not asked).
  const auto take_specified = [&] {
    e.noise = specified_at_known_tau(options);
    specified_over_range = !e.noise.white() && options.known_tau && options.known_tau->range();
  };
  const auto over_range_words = [&]() -> std::string {
    if (!specified_over_range) return "";
    return "; at " + options.known_tau->words() + ", the sigmas averaged over them";
  };
  if (options.mode == Mode::white) {
    e.how =
        "white noise assumed: each dwell mean independent, with the standard error of its "
        "dwell (sigma / sqrt(n)); not tested against bias wander";
  } else if (options.mode == Mode::specified) {
    take_specified();
    e.how = "the specified bias instability, not tested against this run" + over_range_words();
  } else if (!can_estimate_wander(rows.size(), X.cols())) {
    // The wander's parameters would leave the fit's chi-square test no degree of freedom.
    take_specified();
    e.how = options.specified.white()
                ? "white noise assumed: too few measurements beyond the model's parameters to "
                  "estimate a bias wander"
                : "the specified bias instability (too few measurements to estimate one)" +
                      over_range_words();
  } else {
    NoiseEstimateOptions estimate = options.estimate;
    if (options.known_tau) estimate.tau_grid_s = options.known_tau->grid_s();
    // Above a floor every time of the range is kept, however the rows weigh it
    // (FitNoiseChoice::sigmas_at_slowest_tau).
    NoiseEstimateOptions wander_estimate = estimate;
    if (above_floor) wander_estimate.plausible_lr = std::numeric_limits<double>::infinity();
    e = estimate_bias_wander(rows, X, y, wander_estimate);
    if (options.known_tau) e.how += "; at " + options.known_tau->words();
    if (options.average_over_wander_sizes && !e.significant && options.specified.white()) {
      plausible_sizes = plausible_wander_sizes(rows, X, y, estimate, options.wander_curves_ug);
      allowed_ug = largest_wander_ug(plausible_sizes);
      e.how += allowed_sizes_words(
          allowed_ug, estimate.plausible_lr,
          options.wander_curves_ug ? options.wander_curves_from : std::string());
    }
    if (!e.significant && !options.specified.white()) {
      take_specified();
      e.how += "; not significant on this run, so the specified bias instability is used";
    } else if (e.significant && !options.specified.white() && options.known_tau) {
      agrees_with_specified = run_agrees_with_specified(rows, X, y, options, e);
      if (agrees_with_specified) take_specified();
    } else if (!e.significant && e.lr > options.weighting_lr) {
      e.noise = e.best;  // weighted for, though not a finding (NoiseFinding.bias_instability false)
      weighted_below_bar = true;
      e.how +=
          "; below the bar of a finding, but weighted for: ignoring a wander that is there "
          "makes every sigma too small";
    }
  }
  if (options.specified_from == kWanderFromRecording && !options.specified.white())
    e.how +=
        "; the unit's wander and correlation times are the ones this recording's own Allan "
        "curves pin (a dwell long enough to show the wander turn over)";
  if (options.specified_from == kWanderFromStaticRecording && !options.specified.white())
    e.how +=
        "; the unit's wander and correlation times are the ones its static recording's Allan "
        "curves pin";
  if (options.specified_from == kWanderFromHeader &&
      (!options.specified.white() || options.known_tau))
    e.how +=
        "; the unit's wander as this recording's header gives it (what its run was made with: "
        "standcald's unit.bias_instability_*)";
  FitNoiseChoice choice{e.noise,
                        weighted_below_bar ? GaussMarkovNoise{} : e.noise,
                        noise_finding(e, positions),
                        {},
                        {},
                        0,
                        0,
                        std::move(plausible_sizes),
                        options.wander_curves_ug.has_value()};
  // Estimated and weighted for: its uncertainty widens the sigmas (a specified one is given).
  const bool finding_weighted = e.significant && !agrees_with_specified;
  if (finding_weighted || weighted_below_bar) {
    choice.scales = e.scales;
    choice.plausible = e.plausible;
    choice.weighted_parameters = e.parameters;
  }
  if (specified_over_range)
    for (double tau_s : options.known_tau->grid_s())
      choice.plausible.push_back({{e.noise.q_g, tau_s}, 1.0});
  if (finding_weighted) choice.parameters = e.parameters;
  choice.sigmas_at_slowest_tau = finding_weighted && above_floor;
  choice.finding.sigmas_allow_wander_up_to_ug = allowed_ug;
  choice.finding.sigmas_allowance_weighs_allan_curves =
      !choice.plausible_sizes.empty() && choice.sizes_weigh_curves;
  if (choice.finding.sigmas_allowance_weighs_allan_curves)
    choice.finding.sigmas_allowance_allan_curves_from = options.wander_curves_from;
  choice.finding.unit_wander_given = !options.specified.white();
  if (choice.finding.unit_wander_given) choice.finding.unit_wander_from = options.specified_from;
  if (weighted_below_bar) choice.finding.source = "estimated";
  if (agrees_with_specified) choice.finding.source = "specified";  // a finding, weighted as given
  if (choice.finding.model == "gauss_markov")
    set_tau_provenance(choice.finding, choice.plausible, options.known_tau);
  return choice;
}

}  // namespace

// A floor Allan curves put under the correlation time (KnownTau::open_above) stands only where
// the run's own rows show the wander under it, as a finding. Curves cannot tell a slow wander
// from a unit still settling after power-on, and taken where the rows show none the floor had
// the fits weigh for a slow wander the run does not have: under white noise after a two-hour
// warm-up settling by 30 ug, the runs weighted for one below the bar at z-variance 0.01-0.03
// (sigmas 6-10x too large) and the norm fit's biases at 0.26-0.31 where 0.54-0.60 without the
// floor (bench/noise, docs/calibration.md).
FitNoiseChoice choose_fit_noise(const std::vector<NoiseRow>& rows, const MatrixXd& X,
                                const VectorXd& y, const FitNoiseOptions& options,
                                const std::vector<PositionAverage>& positions) {
  FitNoiseChoice choice = choose_fit_noise_as_given(rows, X, y, options, positions);
  if (!options.known_tau || !options.known_tau->open_above || choice.finding.bias_instability)
    return choice;
  FitNoiseOptions without_floor = options;
  without_floor.known_tau.reset();
  choice = choose_fit_noise_as_given(rows, X, y, without_floor, positions);
  choice.tau_floor_set_aside = true;
  choice.finding.how += tau_floor_set_aside_words(options.known_tau->min_s);
  return choice;
}

std::string tau_floor_set_aside_words(double floor_s) {
  return "; the floor " + seconds_text(floor_s) +
         " s that a long static stretch's Allan curves put under the correlation time is set "
         "aside: this run's rows do not show the wander at those times, and curves cannot tell "
         "a slow wander from a unit still settling";
}

bool may_take_recording_wander(const FitNoiseOptions& options) {
  return options.mode == FitNoiseOptions::Mode::estimate && options.specified.white() &&
         !options.known_tau;
}

double shortest_model_tau_s(const FitNoiseOptions& options) {
  const std::vector<double>& grid_s = options.estimate.tau_grid_s;
  return grid_s.empty() ? 0.0 : *std::min_element(grid_s.begin(), grid_s.end());
}

double longest_model_tau_s(const FitNoiseOptions& options) {
  const std::vector<double>& grid_s = options.estimate.tau_grid_s;
  return grid_s.empty() ? 0.0 : *std::max_element(grid_s.begin(), grid_s.end());
}

bool take_recording_tau_floor(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                              const std::string& from) {
  return allan && take_tau_floor(options, allan->wander_tau_floor_s, from);
}

bool take_tau_floor(FitNoiseOptions& options, double floor_s, const std::string& from) {
  if (!may_take_recording_wander(options)) return false;
  if (!(floor_s > shortest_model_tau_s(options))) return false;  // it excludes nothing
  options.known_tau = KnownTau{floor_s, std::max(floor_s, longest_model_tau_s(options)), true};
  options.specified_from = from;
  return true;
}

std::string take_higher_tau_floor(FitNoiseOptions& options, double static_floor_s,
                                  const std::optional<AllanFinding>& allan) {
  const double own_floor_s = allan ? allan->wander_tau_floor_s : 0;
  if (static_floor_s > own_floor_s &&
      take_tau_floor(options, static_floor_s, kWanderFromStaticRecording))
    return kWanderFromStaticRecording;
  return take_recording_tau_floor(options, allan) ? kWanderFromRecording : "";
}

bool may_weigh_wander_curves(const FitNoiseOptions& options) {
  return options.mode == FitNoiseOptions::Mode::estimate && options.specified.white();
}

namespace {
bool take_curves(FitNoiseOptions& options, const WanderCurves& curves, const std::string& from) {
  if (!may_weigh_wander_curves(options)) return false;
  if (curves.curves_end_s < shortest_model_tau_s(options)) return false;
  options.wander_curves_ug = curves;
  options.wander_curves_from = from;
  options.average_over_wander_sizes = true;  // the curves weigh the sizes only there
  return true;
}
}  // namespace

bool take_wander_curves(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                        const std::string& from) {
  return allan && allan->wander_curves && take_curves(options, *allan->wander_curves, from);
}

bool take_header_static_curves(FitNoiseOptions& options, const Recording& rec) {
  const std::string text = rec.header_value(kHeaderUnitStaticCurves);
  if (text.empty() || !may_weigh_wander_curves(options)) return false;
  try {
    return take_curves(options, parse_wander_curves(text), kWanderFromStaticRecording);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(rec.source + ": header '" + kHeaderUnitStaticCurves +
                             "': not the Allan curves of a static recording: " + e.what());
  }
}

bool take_recording_wander_or_bound(FitNoiseOptions& options,
                                    const std::optional<AllanFinding>& allan) {
  if (take_recording_wander(options, allan) || take_recording_tau_floor(options, allan))
    return true;
  return !options.wander_curves_ug && take_wander_curves(options, allan);
}

bool take_recording_wander(FitNoiseOptions& options, const std::optional<AllanFinding>& allan,
                           const std::string& from) {
  if (!may_take_recording_wander(options) || !allan || !allan->wander) return false;
  const WanderToGive& w = *allan->wander;
  // The curves must reach the Allan peak of the longest correlation time they allow
  // (curves_show_turnover; until 2026-12-07 that time itself), as one long dwell's do, and
  // those times reach the ones the fits' wander model takes (its grid's shortest, 60 s): a 10 s
  // dwell's curves (to 3.3 s) then give nothing whatever they show. Without either, pooled
  // 10 s dwells had given a wander of 10x the dwell error in 13 of 1000 runs at tau 60 s and 2
  // of 1000 at tau 300 s (bench/noise), the latter's biases' z-variance 0.61-0.71 becoming
  // 0.70-0.73 over the 1000 runs. Curves short of the peak put a floor instead
  // (wander_tau_floor_s).
  if (!curves_show_turnover(w.tau_max_s, w.curves_end_s) ||
      w.tau_max_s < shortest_model_tau_s(options))
    return false;
  given_wander_of(w).give_to(options, from);
  return true;
}

Vec3 GivenWander::axes_ug() const {
  return size_axes_ug.isZero() ? Vec3::Constant(size_ug) : size_axes_ug;
}

GaussMarkovNoise GivenWander::specified() const {
  return {axes_ug() * kUg, known_tau ? known_tau->centre_s() : tau_s};
}

void GivenWander::give_to(FitNoiseOptions& options, const std::string& from) const {
  options.specified = specified();
  options.known_tau = known_tau;
  options.specified_from = from;
}

void set_unit_wander_header(Recording& header, const GivenWander& w) {
  std::erase_if(header.header, [](const auto& kv) {
    return kv.first == kHeaderUnitWanderUg || kv.first == kHeaderUnitWanderTauS ||
           kv.first == kHeaderUnitWanderTauMaxS ||
           std::find(kHeaderUnitWanderAxisUg.begin(), kHeaderUnitWanderAxisUg.end(), kv.first) !=
               kHeaderUnitWanderAxisUg.end();
  });
  header.unit_wander = {w.size_ug, w.known_tau ? w.known_tau->min_s : 0,
                        w.known_tau && w.known_tau->range() ? w.known_tau->max_s : 0,
                        w.size_axes_ug};
  // Always, 0 for none: a header that says nothing is a run's from before headers carried it
  // (header_silent_on_unit_wander).
  header.set_header(kHeaderUnitWanderUg, round_trip_text(w.size_ug));
  if (!w.size_axes_ug.isZero())
    for (int a = 0; a < 3; ++a)
      header.set_header(kHeaderUnitWanderAxisUg[static_cast<std::size_t>(a)],
                        round_trip_text(w.size_axes_ug[a]));
  if (!w.known_tau) return;
  header.set_header(kHeaderUnitWanderTauS, round_trip_text(w.known_tau->min_s));
  if (w.known_tau->range())
    header.set_header(kHeaderUnitWanderTauMaxS, round_trip_text(w.known_tau->max_s));
}

GivenWander given_wander_of(const WanderToGive& pinned) {
  GivenWander w;
  w.size_ug = pinned.q;
  if (pinned.q_axes.size() == 3)
    w.size_axes_ug = Vec3(pinned.q_axes[0], pinned.q_axes[1], pinned.q_axes[2]);
  w.known_tau = KnownTau{pinned.tau_min_s, pinned.tau_max_s};
  return w;
}

GivenWander given_wander_of(const RecordedUnitWander& recorded) {
  GivenWander w;
  w.size_ug = recorded.size_ug;
  w.size_axes_ug = recorded.size_axes_ug;
  if (recorded.tau_s > 0)
    w.known_tau = KnownTau{recorded.tau_s, std::max(recorded.tau_s, recorded.tau_max_s)};
  return w;
}

bool take_header_wander(FitNoiseOptions& options, const Recording& rec) {
  const GivenWander w = given_wander_of(rec.unit_wander);
  if (!may_take_recording_wander(options) || !w.given()) return false;
  w.give_to(options, kWanderFromHeader);
  return true;
}

bool header_silent_on_unit_wander(const Recording& rec) {
  // A header of the correlation time alone (unit.bias_instability_tau_s configured, no size)
  // says something: written before the size was written always.
  return !given_wander_of(rec.unit_wander).given() &&
         rec.header_value(kHeaderUnitWanderUg).empty() &&
         rec.header_value(kHeaderUnitWanderSource).empty() &&
         rec.header_value(kHeaderUnitStaticCurves).empty() &&
         rec.header_value(kHeaderUnitStaticTauFloorS).empty();
}

bool take_unit_wander(FitNoiseOptions& options, const Recording& rec,
                      const std::optional<AllanFinding>& allan,
                      std::optional<double> static_tau_floor_s) {
  if (take_header_wander(options, rec) || take_recording_wander(options, allan)) return true;
  return !take_higher_tau_floor(options, static_tau_floor_s.value_or(rec.unit_static_tau_floor_s),
                                allan)
              .empty();
}

std::string specified_axes_words(const NoiseFinding& n) {
  const std::array<bool, 3>& kept = n.wander_axes_specified;
  const std::string names = axis_names({kept[0], kept[1], kept[2]});
  if (names.empty()) return "";
  return ", " + names + " at the given size (this run's own is smaller there)";
}

std::string sigmas_allowance_words(const NoiseFinding& n, const std::string& rows) {
  if (n.sigmas_allow_wander_up_to_ug <= 0) return "";
  const char* curves = !n.sigmas_allowance_weighs_allan_curves ? ""
                       : n.sigmas_allowance_allan_curves_from == kWanderFromStaticRecording
                           ? " and the unit's static recording"
                           : " and their Allan curves";
  char size_ug[32];
  std::snprintf(size_ug, sizeof size_ug, "%.3g", n.sigmas_allow_wander_up_to_ug);
  return "; the sigmas allow for a bias wander of up to " + std::string(size_ug) +
         " ug that these " + rows + curves + " cannot exclude";
}

std::string unit_wander_advice(const NoiseFinding& n, bool static_recording_given) {
  if (n.model != "gauss_markov" || n.source != "estimated" || n.unit_wander_given) return "";
  // Measured: the biases' z-variance 0.23-5.0 with the wander estimated from one
  // quarter-hour run (tau 60-1200 s), 0.89-1.04 given what `standcal noise` measures of an
  // 8-hour static recording (docs/calibration.md, "Monte Carlo" and "The whole workflow").
  const std::string why =
      "the sigmas rest on a wander estimated from this run alone, which one "
      "run pins poorly (its correlation time most): ";
  const std::string options =
      "--bias-instability-ug, --bias-instability-tau-s and --bias-instability-tau-max-s";
  if (static_recording_given)
    return why +
           "the unit's static recording given did not pin one (below); give one of about 100 x "
           "the correlation time (8 h for 300 s), whose Allan curves pin it, or in its place "
           "the unit's measured wander with " +
           options;
  return why +
         "give the unit's, as `standcal noise` measures it on a static recording of about "
         "100 x its correlation time (8 h for 300 s), with " +
         options;
}

double KnownTau::centre_s() const { return std::sqrt(min_s * max_s); }

std::vector<double> KnownTau::grid_s() const {
  if (!range()) return {min_s};
  std::vector<double> grid;
  for (int k = 0; k < kKnownTauRangePoints; ++k)
    grid.push_back(min_s * std::pow(max_s / min_s, k / (kKnownTauRangePoints - 1.0)));
  return grid;
}

std::string seconds_text(double s) {
  char b[32];
  std::snprintf(b, sizeof b, s >= 10 ? "%.0f" : "%.3g", s);
  return b;
}

std::string KnownTau::seconds() const {
  return (range() ? seconds_text(min_s) + "-" + seconds_text(max_s) : seconds_text(min_s)) + " s";
}

std::string KnownTau::words() const {
  if (open_above && range())
    return "correlation times " + seconds() +
           ": from the shortest that Allan curves of a long static stretch allow (they see a "
           "wander they do not pin) to the longest the fits model";
  if (open_above)
    return "the correlation time " + seconds() +
           ": the shortest that Allan curves of a long static stretch allow (they see a wander "
           "they do not pin), at or beyond the longest the fits model";
  return (range() ? "the given correlation times " : "the given correlation time ") + seconds();
}

AllanPeak gauss_markov_allan_peak(double q, double tau_s) {
  AllanPeak peak;
  for (double T = 0.01 * tau_s; T < 100 * tau_s; T *= 1.02) {
    const double dev = q * std::sqrt(gauss_markov_allan_variance(tau_s, T));
    if (dev > peak.deviation) peak = {dev, T};
  }
  return peak;
}

}  // namespace standcal
