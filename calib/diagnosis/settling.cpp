#include "calib/diagnosis/settling.hpp"

#include "calib/golden_section.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "calib/averaging.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/diagnosis/selection.hpp"
#include "calib/diagnosis/words.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

SettlingResult settling_search(const Recording& rec, const std::vector<PositionAverage>& avg,
                               int axis, double tau_s) {
  SettlingResult res;
  res.axis = axis;
  res.tau_s = tau_s;
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < avg.size(); ++k) index[avg[k].pos] = k;
  const std::size_t npos = avg.size();
  std::vector<double> sum_e(npos, 0), sum_de(npos, 0), sum_t(npos, 0), count(npos, 0);
  const double g = rec.g_local_mps2;
  const double warmup_end = warmup_end_s(rec);  // a warm-up's rows are not in the means
  for (const RecordingSample& s : rec.samples) {
    if (is_warmup_row(s, warmup_end)) continue;
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
  // Each dwell's sample sigma, widened as its mean's error was for correlated samples (a
  // transient spans the dwell, as the mean does).
  std::vector<double> sigma(npos);
  for (std::size_t k = 0; k < npos; ++k)
    sigma[k] = std::max(avg[k].sigma_g[axis] * correlation_widening(avg[k], axis), 1e-9);
  for (const RecordingSample& s : rec.samples) {
    if (is_warmup_row(s, warmup_end)) continue;
    const std::size_t k = index.at(s.pos);
    const double sig = sigma[k];
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

namespace {

// The best settling transient of one axis: the tau grid, then a golden-section refinement
// of log tau between the best grid point's neighbours (only when the grid found something
// worth refining: the refinement costs passes over the raw samples).
SettlingResult best_settling(const Recording& rec, const std::vector<PositionAverage>& avg,
                             int axis, const std::vector<double>& tau_grid_s,
                             double refine_above_chi2) {
  SettlingResult best;
  std::size_t best_i = 0;
  for (std::size_t i = 0; i < tau_grid_s.size(); ++i) {
    const SettlingResult r = settling_search(rec, avg, axis, tau_grid_s[i]);
    if (r.delta_chi2 > best.delta_chi2) {
      best = r;
      best_i = i;
    }
  }
  if (best.delta_chi2 <= refine_above_chi2 || tau_grid_s.size() < 2) return best;
  double lo = std::log(tau_grid_s[best_i > 0 ? best_i - 1 : 0]);
  double hi = std::log(tau_grid_s[std::min(best_i + 1, tau_grid_s.size() - 1)]);
  auto eval = [&](double log_tau) { return settling_search(rec, avg, axis, std::exp(log_tau)); };
  const SettlingResult refined =
      golden_section_max(eval, lo, hi, 12, [](const SettlingResult& a, const SettlingResult& b) {
        return a.delta_chi2 > b.delta_chi2;
      }).second;
  return refined.delta_chi2 > best.delta_chi2 ? refined : best;
}

}  // namespace

std::vector<SettlingResult> settling_findings(const Recording& rec,
                                              const std::vector<PositionAverage>& avg,
                                              const DiagnoseOptions& options,
                                              std::vector<CandidateTest>& tests) {
  std::vector<SettlingResult> found;
  for (int a = 0; a < 3; ++a) {
    SettlingResult best =
        best_settling(rec, avg, a, options.settling_tau_grid_s, options.significance_chi2);
    best.sigma_ug = best.sigma_free_tau_ug;  // tau was estimated from the same samples
    CandidateTest t{"settling_transient",
                    kAxisNames[a],
                    "ug",
                    true,
                    "",
                    best.amplitude_ug,
                    best.sigma_ug,
                    best.delta_chi2,
                    bic_gain(best.delta_chi2, 2, rec.samples.size()),
                    best.press_gain,
                    best.tau_s};
    if (!std::isfinite(t.value) || !std::isfinite(t.sigma) || !std::isfinite(t.delta_chi2)) {
      t.testable = false;  // never reported with a number
      t.reason = kNoFiniteValue;
    }
    tests.push_back(t);
    if (t.testable && best.delta_chi2 > options.significance_chi2 && t.delta_bic > 0 &&
        best.press_gain > 0)
      found.push_back(best);
  }
  return found;
}

Finding settling_finding(const SettlingResult& s) {
  Finding f{"settling_transient",
            kAxisNames[s.axis],
            "ug",
            s.amplitude_ug,
            s.sigma_ug,
            s.tau_s,
            s.delta_chi2,
            kNaN,
            kNaN,
            "",
            "",
            0};
  f.explanation = std::string("Raw samples of the ") + kAxisNames[s.axis] +
                  " accelerometer decay inside each dwell after arrival (chi2 gain " +
                  fmt("%.0f", s.delta_chi2) +
                  " on the samples). Missing physics: " + effect_words(f.effect, f.axis) + ", " +
                  num(s.amplitude_ug) + " +- " + fmt("%.1f", s.sigma_ug) + " ug at arrival, tau " +
                  fmt("%.1f", s.tau_s) +
                  " s (grid search, refined). In the per-position means it looks like a bias, "
                  "which is now corrected.";
  return f;
}

void remove_settling(std::vector<PositionAverage>& avg, const std::vector<SettlingResult>& found) {
  for (const SettlingResult& s : found)
    for (std::size_t k = 0; k < avg.size(); ++k)
      avg[k].mean_g[s.axis] -= s.amplitude_ug * kUg * s.mean_shape[k];
}

}  // namespace standcal::diagnosis
