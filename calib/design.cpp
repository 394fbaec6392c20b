#include "calib/design.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

#include "calib/model.hpp"
#include "calib/noise_model.hpp"
#include "calib/units.hpp"

namespace standcal {
namespace {

constexpr double kRidge = 1e-12;  // keeps a momentarily singular information matrix invertible

Eigen::MatrixXd information_of(const DesignBasis& basis, const std::vector<double>& weights) {
  const int p = basis.columns();
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(p, p);
  for (std::size_t k = 0; k < basis.blocks.size(); ++k) {
    const double w = weights.empty() ? 1.0 : weights[k];
    if (w != 0) m.noalias() += w * basis.blocks[k].transpose() * basis.blocks[k];
  }
  return m;
}

// Every pose's rows in one matrix, so an iteration of minimax_weights is two matrix
// products rather than one small product per pose (continuous_lower_bound_s: thousands).
struct StackedRows {
  Eigen::MatrixXd rows;
  std::vector<Eigen::Index> first_row;  // pose k owns rows first_row[k] .. first_row[k+1]-1
  Eigen::Index count(int k) const { return first_row[k + 1] - first_row[k]; }
};

StackedRows stack_rows(const DesignBasis& basis) {
  StackedRows s;
  s.first_row.push_back(0);
  for (const auto& block : basis.blocks) s.first_row.push_back(s.first_row.back() + block.rows());
  s.rows.resize(s.first_row.back(), basis.columns());
  for (std::size_t k = 0; k < basis.blocks.size(); ++k)
    s.rows.middleRows(s.first_row[k], basis.blocks[k].rows()) = basis.blocks[k];
  return s;
}

Eigen::MatrixXd inverse_of(const Eigen::MatrixXd& m) {
  // Equilibrate first: columns mix g, rad and angle-scale units.
  const Eigen::VectorXd d = m.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  Eigen::MatrixXd s = d.asDiagonal() * m * d.asDiagonal();
  s.diagonal().array() += kRidge;
  const Eigen::MatrixXd inv = s.ldlt().solve(Eigen::MatrixXd::Identity(m.rows(), m.cols()));
  return d.asDiagonal() * inv * d.asDiagonal();
}

std::vector<int> observable_unit_columns(const DesignBasis& basis) {
  std::vector<int> cols;
  for (int c : basis.unit_column)
    if (c >= 0) cols.push_back(c);
  return cols;
}

// Unit-parameter block of the covariance (nuisance parameters marginalised).
Eigen::MatrixXd unit_covariance(const DesignBasis& basis, const Eigen::MatrixXd& information) {
  const Eigen::MatrixXd cov = inverse_of(information);
  const std::vector<int> cols = observable_unit_columns(basis);
  Eigen::MatrixXd out(static_cast<int>(cols.size()), static_cast<int>(cols.size()));
  for (std::size_t i = 0; i < cols.size(); ++i)
    for (std::size_t j = 0; j < cols.size(); ++j)
      out(static_cast<int>(i), static_cast<int>(j)) = cov(cols[i], cols[j]);
  return out;
}

std::string unit_description(int i) {
  static const std::array<const char*, kUnitParameterCount> words{"bias x",  "bias y",  "bias z",
                                                                  "scale x", "scale y", "scale z",
                                                                  "gamma12", "gamma13", "gamma23"};
  return words[i];
}

DesignBasis invariant_basis(const std::vector<StandPose>& poses) {
  DesignBasis basis;
  basis.model = DesignModel::invariant;
  Eigen::MatrixXd h(static_cast<int>(poses.size()), kUnitParameterCount);
  for (std::size_t k = 0; k < poses.size(); ++k)
    h.row(static_cast<int>(k)) = invariant_regressor(up_vector(
        poses[k].alpha1_deg * kDegToRad, poses[k].alpha2_deg * kDegToRad, poses[k].mount));
  // Keep parameters in order while they add a new direction (same rule as the full model).
  std::vector<int> kept;
  Eigen::MatrixXd q(h.rows(), 0);
  for (int j = 0; j < kUnitParameterCount; ++j) {
    basis.unit_column[j] = -1;
    const double norm = h.col(j).norm();
    if (norm < 1e-9) {
      basis.unobservable_reason[j] = "the invariant measurement cannot see " + unit_description(j) +
                                     ": its regressor is zero at every position of this programme";
      continue;
    }
    Eigen::VectorXd r = h.col(j) / norm;
    r -= q * (q.transpose() * r);
    r -= q * (q.transpose() * r);
    if (r.norm() < 1e-3) {
      basis.unobservable_reason[j] = "this programme cannot separate " + unit_description(j) +
                                     " from the other parameters in the invariant model";
      continue;
    }
    basis.unit_column[j] = static_cast<int>(kept.size());
    kept.push_back(j);
    q.conservativeResize(Eigen::NoChange, q.cols() + 1);
    q.col(q.cols() - 1) = r / r.norm();
  }
  for (int j : kept) basis.parameter_names.emplace_back(kUnitParameterNames[j]);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    Eigen::MatrixXd block(1, static_cast<int>(kept.size()));
    for (std::size_t i = 0; i < kept.size(); ++i)
      block(0, static_cast<int>(i)) = h(static_cast<int>(k), kept[i]);
    basis.blocks.push_back(block);
    basis.projections.push_back(
        up_vector(poses[k].alpha1_deg * kDegToRad, poses[k].alpha2_deg * kDegToRad, poses[k].mount)
            .transpose());
  }
  for (int j = 0; j < kUnitParameterCount; ++j)
    if (!basis.unobservable_reason[j].empty()) basis.notes.push_back(basis.unobservable_reason[j]);
  return basis;
}

DesignBasis full_basis(const std::vector<StandPose>& poses, MountingModel mounting) {
  DesignBasis basis;
  basis.model = DesignModel::full;
  const FullModelLayout layout = full_model_layout(poses, mounting);
  const Observability obs = analyse_observability(layout, poses);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(layout.size());
  for (const auto& pose : poses) {
    const Eigen::MatrixXd jac = full_model_jacobian(layout, nominal, pose);
    Eigen::MatrixXd block(3, static_cast<int>(obs.kept.size()));
    for (std::size_t i = 0; i < obs.kept.size(); ++i)
      block.col(static_cast<int>(i)) = jac.col(obs.kept[i]);
    basis.blocks.push_back(block);
    basis.projections.push_back(Eigen::Matrix3d::Identity());
  }
  basis.parameter_names = obs.kept_combination_names;
  for (int j = 0; j < kUnitParameterCount; ++j) {
    basis.unobservable_reason[j] = unit_unobservable_reason(layout, obs, j);
    const auto it = std::find(obs.kept.begin(), obs.kept.end(), j);
    basis.unit_column[j] =
        basis.unobservable_reason[j].empty() ? static_cast<int>(it - obs.kept.begin()) : -1;
  }
  basis.notes = obs.notes;
  return basis;
}

double angle_distance_deg(double a, double b) { return std::abs(a - b); }

}  // namespace

std::string design_model_name(DesignModel m) {
  return m == DesignModel::invariant ? "invariant" : "full";
}

std::array<double, kUnitParameterCount> AccuracyTarget::sigma_internal() const {
  std::array<double, kUnitParameterCount> out{};
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const double report = i < 3 ? bias_ug : i < 6 ? scale_ppm : gamma_arcsec;
    out[i] = report / report_scale(i);
  }
  return out;
}

AccuracyTarget parse_accuracy_target(const std::string& text) {
  AccuracyTarget t;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("target '" + item + "': expected key=value, e.g. bias=2ug");
    const std::string key = item.substr(0, eq);
    std::string value = item.substr(eq + 1);
    std::size_t used = 0;
    double number = 0;
    try {
      number = std::stod(value, &used);
    } catch (const std::exception&) {
      throw std::invalid_argument("target '" + item + "': '" + value + "' is not a number");
    }
    const std::string unit = value.substr(used);
    auto expect_unit = [&](std::initializer_list<const char*> allowed) {
      if (unit.empty()) return;
      for (const char* a : allowed)
        if (unit == a) return;
      throw std::invalid_argument("target '" + item + "': unknown unit '" + unit + "'");
    };
    if (!(number > 0)) throw std::invalid_argument("target '" + item + "': must be positive");
    if (key == "bias") {
      expect_unit({"ug"});
      t.bias_ug = number;
    } else if (key == "scale") {
      expect_unit({"ppm"});
      t.scale_ppm = number;
    } else if (key == "gamma") {
      expect_unit({"asec", "arcsec", "\""});
      t.gamma_arcsec = number;
    } else {
      throw std::invalid_argument("target '" + item + "': unknown key '" + key +
                                  "' (bias, scale, gamma)");
    }
  }
  return t;
}

std::vector<StandPose> poses_of(const Program& program) {
  std::vector<StandPose> poses;
  for (const auto& p : program.positions) poses.push_back({p.alpha1_deg, p.alpha2_deg, p.mount});
  return poses;
}

DesignBasis design_basis(const std::vector<StandPose>& poses, DesignModel model,
                         MountingModel mounting) {
  if (poses.empty()) throw std::invalid_argument("the programme has no positions");
  return model == DesignModel::invariant ? invariant_basis(poses) : full_basis(poses, mounting);
}

namespace {

// bench_time's timeline: per position re-mount, move, settle, then the dwell.
struct Schedule {
  BenchTime time;
  std::vector<DwellWindow> dwells;
};

Schedule schedule_of(const Program& program, const DesignSettings& settings,
                     const std::vector<double>& dwell_s) {
  Schedule s;
  BenchTime& t = s.time;
  double a1 = 0, a2 = 0;
  std::optional<Mount> mount;
  for (std::size_t k = 0; k < program.positions.size(); ++k) {
    const ProgramPosition& p = program.positions[k];
    if (mount && *mount != p.mount) {
      ++t.remounts;
      t.remount_s += settings.remount_s;
    }
    mount = p.mount;
    // Both axes move at once: the longer of the two moves sets the time.
    t.move_s +=
        std::max(angle_distance_deg(p.alpha1_deg, a1), angle_distance_deg(p.alpha2_deg, a2)) /
        settings.move_rate_deg_s;
    a1 = p.alpha1_deg;
    a2 = p.alpha2_deg;
    t.settle_s += p.settle_s.value_or(settings.settle_s);
    if (k == 0) t.warmup_s = program.warmup_s;  // held before the first dwell
    const double dwell = k < dwell_s.size() ? dwell_s[k] : p.dwell_s.value_or(settings.dwell_s);
    s.dwells.push_back({t.total_s(), dwell});
    t.dwell_s += dwell;
  }
  return s;
}

}  // namespace

BenchTime bench_time(const Program& program, const DesignSettings& settings,
                     const std::vector<double>& dwell_s) {
  return schedule_of(program, settings, dwell_s).time;
}

std::vector<DwellWindow> dwell_windows(const Program& program, const DesignSettings& settings,
                                       const std::vector<double>& dwell_s) {
  return schedule_of(program, settings, dwell_s).dwells;
}

double wander_mean_covariance(const DwellWindow& a, const DwellWindow& b, double tau_s) {
  const DwellWindow& first = a.start_s <= b.start_s ? a : b;
  const DwellWindow& second = a.start_s <= b.start_s ? b : a;
  const bool same = first.start_s == second.start_s && first.length_s == second.length_s;
  if (!same && second.start_s < first.start_s + first.length_s)
    throw std::invalid_argument("wander_mean_covariance: dwell windows that partly overlap");
  return gauss_markov_window_correlation(a.start_s, a.length_s, b.start_s, b.length_s, tau_s);
}

KnownTau DesignSettings::wander_tau() const {
  return {bias_instability_tau_s, std::max(bias_instability_tau_s, bias_instability_tau_max_s)};
}

namespace {

// G^T C^-1 G for the dwell windows under white noise and the wander at one correlation time.
Eigen::MatrixXd information_under_wander(const DesignBasis& basis,
                                         const std::vector<DwellWindow>& windows,
                                         const DesignSettings& settings, double tau_s) {
  const double n_g = settings.noise_density_ug_rthz * kUg;
  const StackedRows g = stack_rows(basis);
  const double q_g = settings.bias_instability_ug * kUg;
  Eigen::MatrixXd c(g.rows.rows(), g.rows.rows());
  for (std::size_t i = 0; i < windows.size(); ++i) {
    const int ki = static_cast<int>(i);
    for (std::size_t j = 0; j <= i; ++j) {
      const int kj = static_cast<int>(j);
      const double k_ij = q_g * q_g * wander_mean_covariance(windows[i], windows[j], tau_s);
      const Eigen::MatrixXd block = k_ij * basis.projections[i] * basis.projections[j].transpose();
      c.block(g.first_row[ki], g.first_row[kj], g.count(ki), g.count(kj)) = block;
      c.block(g.first_row[kj], g.first_row[ki], g.count(kj), g.count(ki)) = block.transpose();
    }
    c.block(g.first_row[ki], g.first_row[ki], g.count(ki), g.count(ki)).diagonal().array() +=
        n_g * n_g / windows[i].length_s;
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(c);
  if (llt.info() != Eigen::Success)
    throw std::runtime_error("the dwell means' covariance is not positive definite");
  return g.rows.transpose() * llt.solve(g.rows);
}

}  // namespace

Eigen::MatrixXd scheduled_information(const DesignBasis& basis, const Program& program,
                                      const DesignSettings& settings,
                                      const std::vector<double>& dwell_s) {
  const std::vector<DwellWindow> windows = dwell_windows(program, settings, dwell_s);
  if (!settings.wander()) {
    const double n_g = settings.noise_density_ug_rthz * kUg;
    std::vector<double> weights;
    for (const DwellWindow& w : windows) weights.push_back(w.length_s / (n_g * n_g));
    return information_of(basis, weights);
  }
  const KnownTau tau = settings.wander_tau();
  if (!tau.range()) return information_under_wander(basis, windows, settings, tau.min_s);
  // As a fit given the range weights a specified wander (noise_model.hpp, choose_fit_noise):
  // each parameter's variance the average over the range's times, and never below the one
  // at the range's log-middle, which it is weighted with; correlations those of the average.
  const std::vector<double> grid_s = tau.grid_s();
  Eigen::MatrixXd averaged = Eigen::MatrixXd::Zero(basis.columns(), basis.columns());
  for (const double tau_s : grid_s)
    averaged += inverse_of(information_under_wander(basis, windows, settings, tau_s));
  averaged /= static_cast<double>(grid_s.size());
  const Eigen::MatrixXd at_middle =
      inverse_of(information_under_wander(basis, windows, settings, tau.centre_s()));
  const Eigen::VectorXd widen =
      (at_middle.diagonal().array() / averaged.diagonal().array()).max(1.0).sqrt().matrix();
  return inverse_of(widen.asDiagonal() * averaged * widen.asDiagonal());
}

Program repeated_program(const Program& program, int times) {
  if (times < 1) throw std::invalid_argument("a programme is visited at least once");
  Program out;
  out.name = times == 1 ? program.name : program.name + " x" + std::to_string(times);
  out.warmup_s = program.warmup_s;  // once, before the first pass
  for (int r = 0; r < times; ++r)
    out.positions.insert(out.positions.end(), program.positions.begin(), program.positions.end());
  return out;
}

double d_criterion(const DesignBasis& basis, const std::vector<double>& weights) {
  for (int c : basis.unit_column)
    if (c < 0) return 0;
  const Eigen::MatrixXd cov = unit_covariance(basis, information_of(basis, weights));
  const double det_cov = cov.determinant();
  return det_cov > 0 ? std::pow(det_cov, -1.0 / kUnitParameterCount) : 0;
}

namespace {

std::array<std::optional<double>, kUnitParameterCount> unit_sigmas(
    const DesignBasis& basis, const Eigen::MatrixXd& information) {
  const Eigen::MatrixXd cov = inverse_of(information);
  std::array<std::optional<double>, kUnitParameterCount> sigma;
  for (int i = 0; i < kUnitParameterCount; ++i)
    if (basis.unit_column[i] >= 0)
      sigma[i] = std::sqrt(cov(basis.unit_column[i], basis.unit_column[i])) * report_scale(i);
  return sigma;
}

}  // namespace

DesignEvaluation evaluate_design(const Program& program, DesignModel model,
                                 const DesignSettings& settings) {
  DesignEvaluation ev;
  ev.program = program.name;
  ev.model = model;
  const DesignBasis basis = design_basis(poses_of(program), model, settings.mounting);
  ev.parameter_names = basis.parameter_names;
  ev.notes = basis.notes;
  ev.unobservable_reason = basis.unobservable_reason;
  for (const auto& p : program.positions)
    ev.dwell_s.push_back(p.dwell_s.value_or(settings.dwell_s));
  ev.information = scheduled_information(basis, program, settings, ev.dwell_s);
  ev.unit_sigma = unit_sigmas(basis, ev.information);
  if (settings.wander()) {
    DesignSettings white = settings;
    white.bias_instability_ug = 0;
    ev.white_unit_sigma =
        unit_sigmas(basis, scheduled_information(basis, program, white, ev.dwell_s));
  }
  ev.d_criterion = d_criterion(basis);
  if (ev.d_criterion > 0)
    ev.a_criterion = unit_covariance(basis, information_of(basis, {})).trace();
  ev.time = bench_time(program, settings, ev.dwell_s);
  return ev;
}

namespace {

// max_j cov_jj / target_j^2 for weights w (sum 1), over the unit parameters.
struct TargetLoad {
  double worst = 0;
  int worst_parameter = -1;
};

TargetLoad load_of(const DesignBasis& basis, const std::array<double, kUnitParameterCount>& target,
                   const Eigen::MatrixXd& information) {
  const Eigen::MatrixXd cov = inverse_of(information);
  TargetLoad load;
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const int c = basis.unit_column[i];
    const double v = cov(c, c) / (target[i] * target[i]);
    if (v > load.worst) {
      load.worst = v;
      load.worst_parameter = i;
    }
  }
  return load;
}

TargetLoad target_load(const DesignBasis& basis,
                       const std::array<double, kUnitParameterCount>& target,
                       const std::vector<double>& w) {
  return load_of(basis, target, information_of(basis, w));
}

std::string first_unobservable(const DesignBasis& basis) {
  for (int i = 0; i < kUnitParameterCount; ++i)
    if (basis.unit_column[i] < 0)
      return std::string(kUnitParameterNames[i]) + ": " + basis.unobservable_reason[i];
  return {};
}

// A programme that cannot see a target parameter cannot meet the target: the plan says
// which, and why.
bool refuse_if_unobservable(const DesignBasis& basis, DwellPlan& plan) {
  plan.reason = first_unobservable(basis);
  plan.feasible = plan.reason.empty();
  return !plan.feasible;
}

// Weights (sum 1) minimising max_j cov_jj(w) / target_j^2. By the minimax theorem this is
// max over lambda (simplex) of min over w of sum_j lambda_j c_j(w): the inner problem is an
// L-optimal design (multiplicative algorithm, optimum where every used pose has phi = 1),
// the outer a multiplicative ascent of lambda towards the constraints that bind.
std::vector<double> minimax_weights(const DesignBasis& basis,
                                    const std::array<double, kUnitParameterCount>& target,
                                    int iterations) {
  const int n = static_cast<int>(basis.blocks.size());
  const StackedRows stacked = stack_rows(basis);
  std::vector<double> w(n, 1.0 / n), best = w;
  Eigen::VectorXd lam = Eigen::VectorXd::Constant(kUnitParameterCount, 1.0 / kUnitParameterCount);
  double best_load = std::numeric_limits<double>::infinity();
  std::array<double, kUnitParameterCount> t2{};
  for (int j = 0; j < kUnitParameterCount; ++j) t2[j] = target[j] * target[j];
  Eigen::VectorXd c(kUnitParameterCount);
  Eigen::VectorXd row_weight(stacked.rows.rows());
  for (int it = 0; it < iterations; ++it) {
    for (int k = 0; k < n; ++k)
      row_weight.segment(stacked.first_row[k], stacked.count(k)).setConstant(w[k]);
    // The information matrix sum_k w_k B_k^T B_k (information_of) as one product.
    const Eigen::MatrixXd info = stacked.rows.transpose() * row_weight.asDiagonal() * stacked.rows;
    const Eigen::MatrixXd cov = inverse_of(info);
    for (int j = 0; j < kUnitParameterCount; ++j)
      c[j] = cov(basis.unit_column[j], basis.unit_column[j]) / t2[j];
    double worst = 0;
    for (int j = 0; j < kUnitParameterCount; ++j) worst = std::max(worst, c[j]);
    if (worst < best_load) {
      best_load = worst;
      best = w;
    }
    const double weighted = lam.dot(c);
    // Inner step (L-optimality for the current lambda): phi_k = |B_k cov_cols|^2.
    Eigen::MatrixXd cov_cols(cov.rows(), kUnitParameterCount);
    for (int j = 0; j < kUnitParameterCount; ++j)
      cov_cols.col(j) = cov.col(basis.unit_column[j]) * std::sqrt(lam[j] / (t2[j] * weighted));
    const Eigen::VectorXd row_phi = (stacked.rows * cov_cols).rowwise().squaredNorm();
    double sum = 0;
    for (int k = 0; k < n; ++k) {
      const double phi = row_phi.segment(stacked.first_row[k], stacked.count(k)).sum();
      w[k] *= std::sqrt(std::max(phi, 0.0));
      sum += w[k];
    }
    for (double& x : w) x /= sum;
    // Outer step: more weight on the constraints above the weighted mean.
    for (int j = 0; j < kUnitParameterCount; ++j) lam[j] *= std::pow(c[j] / weighted, 0.5);
    lam /= lam.sum();
  }
  return best;
}

}  // namespace

DwellPlan equal_dwell_for_target(const DesignBasis& basis, const AccuracyTarget& target,
                                 const DesignSettings& settings) {
  DwellPlan plan;
  if (refuse_if_unobservable(basis, plan)) return plan;
  const int n = static_cast<int>(basis.blocks.size());
  const std::vector<double> w(n, 1.0 / n);
  const TargetLoad load = target_load(basis, target.sigma_internal(), w);
  const double n_g = settings.noise_density_ug_rthz * kUg;
  plan.total_dwell_s = n_g * n_g * load.worst;
  plan.dwell_s.assign(n, plan.total_dwell_s / n);
  plan.limiting_parameter = std::string(kUnitParameterNames[load.worst_parameter]);
  return plan;
}

DwellPlan allocated_dwell_for_target(const DesignBasis& basis, const AccuracyTarget& target,
                                     const DesignSettings& settings) {
  DwellPlan plan;
  if (refuse_if_unobservable(basis, plan)) return plan;
  const auto t = target.sigma_internal();
  const std::vector<double> w = minimax_weights(basis, t, 3000);
  const TargetLoad load = target_load(basis, t, w);
  const double n_g = settings.noise_density_ug_rthz * kUg;
  plan.total_dwell_s = n_g * n_g * load.worst;
  for (double x : w) plan.dwell_s.push_back(x * plan.total_dwell_s);
  plan.limiting_parameter = std::string(kUnitParameterNames[load.worst_parameter]);
  return plan;
}

namespace {

// The least scale s (a dwell or a total) whose target load is at most 1: a geometric scan
// from lo to hi, then bisection in log s between the last scan point that fails and the
// first that meets it. Without such an s up to hi, the best load the scan saw. Under wander
// the load need not fall monotonically with the dwell (neighbouring dwells decorrelate as
// they lengthen), so a dwell found always meets the target, and is the least one to the
// scan's resolution (a factor 1.25) rather than provably the least.
struct DwellSearch {
  bool found = false;
  double s = 0;
  TargetLoad load;  // at s: the found one, or the best seen
};

DwellSearch least_scale_meeting(const std::function<TargetLoad(double)>& load_at, double lo,
                                double hi) {
  constexpr double kStep = 1.25;
  DwellSearch best;
  best.load.worst = std::numeric_limits<double>::infinity();
  double failing = 0;
  for (double s = lo;; s = std::min(s * kStep, hi)) {
    const TargetLoad load = load_at(s);
    if (load.worst <= 1) {
      best = {true, s, load};
      break;
    }
    failing = s;
    if (load.worst < best.load.worst) best = {false, s, load};
    if (s >= hi) break;  // hi itself is tried: a floor is stated for the whole range
  }
  if (!best.found || failing == 0) return best;
  for (int it = 0; it < 40 && best.s / failing > 1 + 1e-4; ++it) {
    const double mid = std::sqrt(failing * best.s);
    const TargetLoad load = load_at(mid);
    if (load.worst <= 1)
      best = {true, mid, load};
    else
      failing = mid;
  }
  return best;
}

// The range searched: 0.1 s to a day per position.
constexpr double kLeastDwellS = 0.1, kLongestDwellS = 86400;

std::string floor_reason(const AccuracyTarget& target, const DesignSettings& settings,
                         const DwellSearch& search, const char* what) {
  const int j = search.load.worst_parameter;
  const double target_report = target.sigma_internal()[j] * report_scale(j);
  char buf[400];
  std::snprintf(
      buf, sizeof buf,
      "the bias wander (%.3g ug, tau %s) keeps %s at %.3g %s or more for any dwell "
      "up to %.0f s per position (target %.3g; least at %.3g s %s)",
      settings.bias_instability_ug, settings.wander_tau().seconds().c_str(),
      std::string(kUnitParameterNames[j]).c_str(), target_report * std::sqrt(search.load.worst),
      std::string(kUnitParameterUnits[j]).c_str(), kLongestDwellS, target_report, search.s, what);
  return buf;
}

// Under wander: the least scale s for which dwells shape * s meet the target on the
// programme's schedule (shape all ones: s is the dwell per position; shape summing to 1: s
// is the total), searched over 0.1 s to a day per position.
DwellPlan plan_under_wander(const DesignBasis& basis, const Program& program,
                            const AccuracyTarget& target, const DesignSettings& settings,
                            const std::vector<double>& shape, const char* scale_words) {
  DwellPlan plan;
  if (refuse_if_unobservable(basis, plan)) return plan;
  const auto t = target.sigma_internal();
  const auto dwells = [&](double scale) {
    std::vector<double> d;
    for (double w : shape) d.push_back(w * scale);
    return d;
  };
  double shape_sum = 0;
  for (double w : shape) shape_sum += w;
  const double per_position = static_cast<double>(shape.size()) / shape_sum;
  const DwellSearch search = least_scale_meeting(
      [&](double scale) {
        return load_of(basis, t, scheduled_information(basis, program, settings, dwells(scale)));
      },
      kLeastDwellS * per_position, kLongestDwellS * per_position);
  if (search.load.worst_parameter < 0) {  // every load the search saw was NaN
    plan.feasible = false;
    plan.reason = "the predicted sigmas are not finite for this programme and noise";
    return plan;
  }
  plan.limiting_parameter = std::string(kUnitParameterNames[search.load.worst_parameter]);
  if (!search.found) {
    plan.feasible = false;
    plan.reason = floor_reason(target, settings, search, scale_words);
    return plan;
  }
  plan.dwell_s = dwells(search.s);
  plan.total_dwell_s = search.s * shape_sum;
  return plan;
}

}  // namespace

DwellPlan equal_dwell_for_target(const DesignBasis& basis, const Program& program,
                                 const AccuracyTarget& target, const DesignSettings& settings) {
  if (!settings.wander()) return equal_dwell_for_target(basis, target, settings);
  return plan_under_wander(basis, program, target, settings,
                           std::vector<double>(program.positions.size(), 1.0), "per position");
}

DwellPlan allocated_dwell_for_target(const DesignBasis& basis, const Program& program,
                                     const AccuracyTarget& target, const DesignSettings& settings) {
  if (!settings.wander()) return allocated_dwell_for_target(basis, target, settings);
  DwellPlan refused;  // before the weights, which need every target parameter observable
  if (refuse_if_unobservable(basis, refused)) return refused;
  return plan_under_wander(basis, program, target, settings,
                           minimax_weights(basis, target.sigma_internal(), 3000), "of total dwell");
}

double continuous_lower_bound_s(DesignModel model, const AccuracyTarget& target,
                                const DesignSettings& settings, const StandLimits& limits) {
  const double step = model == DesignModel::invariant ? 5.0 : 10.0;
  std::vector<StandPose> candidates;
  std::map<std::array<long, 3>, bool> seen_up;  // the invariant model only sees u: one pose per u
  for (double a1 : axis_grid_deg(limits.alpha1, step)) {
    for (double a2 : axis_grid_deg(limits.alpha2, step)) {
      if (model == DesignModel::invariant) {
        const Vec3 u = up_vector(a1 * kDegToRad, a2 * kDegToRad);
        const std::array<long, 3> key{std::lround(u.x() * 1e6), std::lround(u.y() * 1e6),
                                      std::lround(u.z() * 1e6)};
        if (!seen_up.emplace(key, true).second) continue;
      }
      candidates.push_back({a1, a2, Mount::x});
    }
  }
  const DesignBasis basis = design_basis(candidates, model);
  if (!first_unobservable(basis).empty()) return std::numeric_limits<double>::infinity();
  const auto t = target.sigma_internal();
  const std::vector<double> w =
      minimax_weights(basis, t, model == DesignModel::invariant ? 1500 : 400);
  const double n_g = settings.noise_density_ug_rthz * kUg;
  return n_g * n_g * target_load(basis, t, w).worst;
}

// ---------------------------------------------------------------------------------------
// D-optimal programmes by coordinate exchange.
namespace {

enum class FreeAxes { both, alpha1_only, alpha2_only, none };

struct Slot {
  FreeAxes free = FreeAxes::both;
  double alpha1_deg = 0;
  double alpha2_deg = 0;
};

Eigen::MatrixXd pose_block(DesignModel model, const FullModelLayout& layout,
                           const std::vector<int>& kept, double a1_deg, double a2_deg) {
  if (model == DesignModel::invariant)
    return invariant_regressor(up_vector(a1_deg * kDegToRad, a2_deg * kDegToRad));
  const Eigen::MatrixXd jac =
      full_model_jacobian(layout, Eigen::VectorXd::Zero(layout.size()), {a1_deg, a2_deg, Mount::x});
  Eigen::MatrixXd block(3, static_cast<int>(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i) block.col(static_cast<int>(i)) = jac.col(kept[i]);
  return block;
}

// The optimisation problem: which slots are free, what basis function each pose has.
// log det from an LDLT's diagonal, or -inf-like when not positive definite. (A loop, not
// minCoeff(): g++ 12 flags Eigen's reduction of a possibly empty vector under -Werror.)
double log_det_of_diagonal(const Eigen::VectorXd& d) {
  double sum = 0;
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (!(d[i] > 1e-300)) return -1e300;
    sum += std::log(d[i]);
  }
  return sum;
}

struct ExchangeProblem {
  DesignModel model;
  FullModelLayout layout;
  std::vector<int> kept;  // full model: parameters estimated (observable over the whole stand)
  std::vector<int> unit_cols;
  StandLimits limits;

  Eigen::MatrixXd block(double a1, double a2) const {
    return pose_block(model, layout, kept, a1, a2);
  }

  // log of the D-criterion on the unit parameters (nuisance marginalised).
  double log_d(const std::vector<Eigen::MatrixXd>& blocks) const {
    const int p = static_cast<int>(kept.size());
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(p, p);
    for (const auto& b : blocks) m.noalias() += b.transpose() * b;
    if (model == DesignModel::invariant) {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
      return log_det_of_diagonal(ldlt.vectorD()) / kUnitParameterCount;
    }
    const Eigen::MatrixXd cov = inverse_of(m);
    Eigen::MatrixXd cu(kUnitParameterCount, kUnitParameterCount);
    for (int i = 0; i < kUnitParameterCount; ++i)
      for (int j = 0; j < kUnitParameterCount; ++j) cu(i, j) = cov(unit_cols[i], unit_cols[j]);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(cu);
    const double log_det_cov = log_det_of_diagonal(ldlt.vectorD());
    return log_det_cov <= -1e299 ? -1e300 : -log_det_cov / kUnitParameterCount;
  }
};

ExchangeProblem make_problem(DesignModel model, const StandLimits& limits) {
  ExchangeProblem pr;
  pr.model = model;
  pr.limits = limits;
  if (model == DesignModel::invariant) {
    for (int i = 0; i < kUnitParameterCount; ++i) {
      pr.kept.push_back(i);
      pr.unit_cols.push_back(i);
    }
    return pr;
  }
  // Parameters observable over the whole reachable stand define the full model to optimise.
  std::vector<StandPose> grid;
  for (double a1 : axis_grid_deg(limits.alpha1, 30))
    for (double a2 : axis_grid_deg(limits.alpha2, 30)) grid.push_back({a1, a2, Mount::x});
  pr.layout = full_model_layout(grid);
  const Observability obs = analyse_observability(pr.layout, grid);
  pr.kept = obs.kept;
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const auto it = std::find(pr.kept.begin(), pr.kept.end(), i);
    if (it == pr.kept.end())
      throw std::runtime_error("the stand cannot observe " + unit_description(i));
    pr.unit_cols.push_back(static_cast<int>(it - pr.kept.begin()));
  }
  return pr;
}

double clamp_to_range(double a, const AxisRange& r) {
  if (r.continuous) return a;
  return std::clamp(a, r.min_deg, r.max_deg);
}

struct ExchangeState {
  std::vector<Slot> slots;
  std::vector<Eigen::MatrixXd> blocks;
};

// Candidate poses on a grid with their blocks stacked (rows m per pose), for fast scans.
struct CandidateSet {
  std::vector<std::pair<double, double>> poses;
  Eigen::MatrixXd stacked;  // (m * poses) x p
  int m = 1;
};

CandidateSet make_candidates(const ExchangeProblem& pr,
                             std::vector<std::pair<double, double>> poses) {
  CandidateSet cs;
  cs.poses = std::move(poses);
  cs.m = pr.model == DesignModel::invariant ? 1 : 3;
  cs.stacked.resize(cs.m * static_cast<int>(cs.poses.size()), static_cast<int>(pr.kept.size()));
  for (std::size_t c = 0; c < cs.poses.size(); ++c)
    cs.stacked.middleRows(cs.m * static_cast<int>(c), cs.m) =
        pr.block(cs.poses[c].first, cs.poses[c].second);
  return cs;
}

// log det(M - Gk^T Gk + Gc^T Gc) - log det(M) for every candidate c, by Sylvester's
// identity on the 2m x 2m matrix I + S U^T M^-1 U, U = [Gk^T Gc^T], S = diag(-I, +I).
Eigen::VectorXd exchange_gain(const Eigen::MatrixXd& m_full, const std::vector<int>& cols,
                              const Eigen::MatrixXd& gk_full, const CandidateSet& cs) {
  const int p = static_cast<int>(cols.size());
  const bool all = p == m_full.cols();
  Eigen::MatrixXd m, gk, gc_subset;
  if (!all) {
    m.resize(p, p);
    gk.resize(cs.m, p);
    gc_subset.resize(cs.stacked.rows(), p);
    for (int i = 0; i < p; ++i) {
      for (int j = 0; j < p; ++j) m(i, j) = m_full(cols[i], cols[j]);
      gk.col(i) = gk_full.col(cols[i]);
      gc_subset.col(i) = cs.stacked.col(cols[i]);
    }
  } else {
    m = m_full;
    gk = gk_full;
  }
  const Eigen::MatrixXd& gc = all ? cs.stacked : gc_subset;
  const Eigen::MatrixXd minv = inverse_of(m);
  const Eigen::MatrixXd gc_minv = gc * minv;
  const Eigen::MatrixXd kk = gk * minv * gk.transpose();
  const Eigen::MatrixXd ck = gc_minv * gk.transpose();
  const int mm = cs.m;
  Eigen::VectorXd gain(static_cast<Eigen::Index>(cs.poses.size()));
  if (mm == 1) {
    // 2 x 2 case in closed form: (1 - g M^-1 g)(1 + h M^-1 h) + (h M^-1 g)^2.
    const Eigen::VectorXd b = gc_minv.cwiseProduct(gc).rowwise().sum();
    const Eigen::ArrayXd det = (1.0 - kk(0, 0)) * (1.0 + b.array()) + ck.col(0).array().square();
    for (Eigen::Index c = 0; c < gain.size(); ++c) gain[c] = det[c] > 0 ? std::log(det[c]) : -1e300;
    return gain;
  }
  Eigen::Matrix<double, 6, 6> s;
  for (Eigen::Index c = 0; c < gain.size(); ++c) {
    const Eigen::Matrix3d ckc = ck.middleRows<3>(3 * c);
    s.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() - kk;
    s.topRightCorner<3, 3>() = -ckc.transpose();
    s.bottomLeftCorner<3, 3>() = ckc;
    s.bottomRightCorner<3, 3>() =
        Eigen::Matrix3d::Identity() +
        gc_minv.middleRows<3>(3 * c) * gc.middleRows<3>(3 * c).transpose();
    const double det = s.determinant();
    gain[c] = det > 0 ? std::log(det) : -1e300;
  }
  return gain;
}

// One sweep: each free slot moves to the best candidate pose given all the others
// (coordinate exchange; for the full model the D_s criterion: log det M - log det M_nuisance).
bool exchange_sweep(const ExchangeProblem& pr, ExchangeState& st, const CandidateSet& both,
                    const CandidateSet& alpha1_line, const CandidateSet& alpha2_line) {
  bool moved = false;
  std::vector<int> all_cols(pr.kept.size()), nuisance_cols;
  for (std::size_t i = 0; i < pr.kept.size(); ++i) all_cols[i] = static_cast<int>(i);
  for (int c : all_cols)
    if (std::find(pr.unit_cols.begin(), pr.unit_cols.end(), c) == pr.unit_cols.end())
      nuisance_cols.push_back(c);
  for (std::size_t k = 0; k < st.slots.size(); ++k) {
    Slot& s = st.slots[k];
    if (s.free == FreeAxes::none) continue;
    const CandidateSet& cs = s.free == FreeAxes::both          ? both
                             : s.free == FreeAxes::alpha1_only ? alpha1_line
                                                               : alpha2_line;
    const int p = static_cast<int>(pr.kept.size());
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(p, p);
    for (const auto& b : st.blocks) m.noalias() += b.transpose() * b;
    Eigen::VectorXd gain = exchange_gain(m, all_cols, st.blocks[k], cs);
    if (!nuisance_cols.empty()) gain -= exchange_gain(m, nuisance_cols, st.blocks[k], cs);
    Eigen::Index best_c = 0;
    const double best_gain = gain.maxCoeff(&best_c);
    // Gains below 1e-7 in log det are grid noise: stop sweeping (the polish refines later).
    if (best_gain <= 1e-7) continue;
    s.alpha1_deg = cs.poses[best_c].first;
    s.alpha2_deg = cs.poses[best_c].second;
    st.blocks[k] = cs.stacked.middleRows(cs.m * best_c, cs.m);
    moved = true;
  }
  return moved;
}

// Pattern search on every free coordinate with a shrinking step, to far below the grid.
void polish(const ExchangeProblem& pr, ExchangeState& st, double start_step_deg) {
  double best = pr.log_d(st.blocks);
  for (double step = start_step_deg; step > 1e-5; step /= 4) {
    bool improved = true;
    while (improved) {
      improved = false;
      for (std::size_t k = 0; k < st.slots.size(); ++k) {
        Slot& s = st.slots[k];
        for (int axis = 0; axis < 2; ++axis) {
          if (s.free == FreeAxes::none) continue;
          if (axis == 0 && s.free == FreeAxes::alpha2_only) continue;
          if (axis == 1 && s.free == FreeAxes::alpha1_only) continue;
          for (double sign : {+1.0, -1.0}) {
            Slot trial = s;
            if (axis == 0)
              trial.alpha1_deg = clamp_to_range(s.alpha1_deg + sign * step, pr.limits.alpha1);
            else
              trial.alpha2_deg = clamp_to_range(s.alpha2_deg + sign * step, pr.limits.alpha2);
            const Eigen::MatrixXd old = st.blocks[k];
            st.blocks[k] = pr.block(trial.alpha1_deg, trial.alpha2_deg);
            const double v = pr.log_d(st.blocks);
            if (v > best + 1e-15) {
              best = v;
              s = trial;
              improved = true;
              break;
            }
            st.blocks[k] = old;
          }
        }
      }
    }
  }
}

std::vector<Slot> initial_slots(const OptimizeOptions& o, std::mt19937_64& rng) {
  auto uniform = [&](const AxisRange& r) {
    const double lo = r.continuous ? -180.0 : r.min_deg, hi = r.continuous ? 180.0 : r.max_deg;
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  std::vector<Slot> slots;
  if (o.paper_structure) {
    for (int i = 0; i < 5; ++i)
      slots.push_back({FreeAxes::alpha1_only, uniform(o.limits.alpha1), 0});
    for (int i = 0; i < 3; ++i)
      slots.push_back({FreeAxes::alpha2_only, 0, uniform(o.limits.alpha2)});
    slots.push_back({FreeAxes::none, 45, 90});
    return slots;
  }
  for (int i = 0; i < o.positions; ++i)
    slots.push_back({FreeAxes::both, uniform(o.limits.alpha1), uniform(o.limits.alpha2)});
  return slots;
}

// Visit order: nearest next position (both axes move at once) from (0, 0), to cut move time.
std::vector<Slot> travel_order(std::vector<Slot> slots) {
  std::vector<Slot> out;
  double a1 = 0, a2 = 0;
  while (!slots.empty()) {
    auto best = std::min_element(slots.begin(), slots.end(), [&](const Slot& x, const Slot& y) {
      return std::max(std::abs(x.alpha1_deg - a1), std::abs(x.alpha2_deg - a2)) <
             std::max(std::abs(y.alpha1_deg - a1), std::abs(y.alpha2_deg - a2));
    });
    a1 = best->alpha1_deg;
    a2 = best->alpha2_deg;
    out.push_back(*best);
    slots.erase(best);
  }
  return out;
}

}  // namespace

OptimizedProgram optimize_program(const OptimizeOptions& options) {
  if (!options.paper_structure && options.positions < kUnitParameterCount)
    throw std::invalid_argument(
        "a programme needs at least 9 positions for the nine unit parameters, got " +
        std::to_string(options.positions));
  const ExchangeProblem pr = make_problem(options.model, options.limits);
  const double step = options.model == DesignModel::invariant ? 3.0 : 6.0;
  // Line candidates serve the paper structure's alpha1-only (alpha2 = 0) and alpha2-only
  // (alpha1 = 0) slots.
  std::vector<std::pair<double, double>> line1, line2, grid2;
  for (double a1 : axis_grid_deg(options.limits.alpha1, step / 6)) line1.emplace_back(a1, 0.0);
  for (double a2 : axis_grid_deg(options.limits.alpha2, step / 6)) line2.emplace_back(0.0, a2);
  if (!options.paper_structure)
    for (double a1 : axis_grid_deg(options.limits.alpha1, step))
      for (double a2 : axis_grid_deg(options.limits.alpha2, step)) grid2.emplace_back(a1, a2);
  const CandidateSet both = make_candidates(pr, grid2);
  const CandidateSet alpha1_line = make_candidates(pr, line1);
  const CandidateSet alpha2_line = make_candidates(pr, line2);

  std::mt19937_64 rng(options.seed);
  OptimizedProgram best;
  double best_log_d = -std::numeric_limits<double>::infinity();
  ExchangeState best_state;
  for (int r = 0; r < std::max(1, options.restarts); ++r) {
    ExchangeState st;
    st.slots = initial_slots(options, rng);
    for (const Slot& s : st.slots) st.blocks.push_back(pr.block(s.alpha1_deg, s.alpha2_deg));
    int sweeps = 0;
    while (sweeps < 30 && exchange_sweep(pr, st, both, alpha1_line, alpha2_line)) ++sweeps;
    best.sweeps += sweeps;
    const double v = pr.log_d(st.blocks);
    if (v > best_log_d) {
      best_log_d = v;
      best_state = st;
    }
  }
  polish(pr, best_state, step);
  best_log_d = pr.log_d(best_state.blocks);

  best.program.name = options.paper_structure ? "d-optimal-paper-structure"
                                              : "d-optimal-" + std::to_string(options.positions);
  auto wrap = [](double a, const AxisRange& r) { return r.continuous ? wrap_deg(a) : a; };
  for (Slot& s : best_state.slots) {
    s.alpha1_deg = wrap(s.alpha1_deg, options.limits.alpha1);
    s.alpha2_deg = wrap(s.alpha2_deg, options.limits.alpha2);
  }
  const std::vector<Slot> ordered =
      options.paper_structure ? best_state.slots : travel_order(best_state.slots);
  for (const Slot& s : ordered) {
    ProgramPosition p;
    p.alpha1_deg = s.alpha1_deg;
    p.alpha2_deg = s.alpha2_deg;
    best.program.positions.push_back(p);
  }
  best.d_criterion = std::exp(best_log_d);
  best.paper9_d_criterion = d_criterion(design_basis(poses_of(paper9()), options.model));
  return best;
}

std::optional<RevisitPlan> fastest_revisit(const Program& program, DesignModel model,
                                           const AccuracyTarget& target,
                                           const DesignSettings& settings, int max_repeats,
                                           const std::optional<RevisitPlan>& one_pass) {
  std::optional<RevisitPlan> best;
  for (int times = 1; times <= std::max(1, max_repeats); ++times) {
    RevisitPlan r;
    if (times == 1 && one_pass) {
      r = *one_pass;
    } else {
      const Program visited = repeated_program(program, times);
      const DesignBasis basis = design_basis(poses_of(visited), model, settings.mounting);
      r = {times, equal_dwell_for_target(basis, visited, target, settings), {}};
      if (r.equal.feasible) r.time = bench_time(visited, settings, r.equal.dwell_s);
    }
    if (!r.equal.feasible) continue;
    if (!best || r.time.total_s() < best->time.total_s()) best = r;
  }
  return best;
}

namespace {

// The bench time a programme visited `times` passes would take to meet the target, judged at
// `dwell_s` per visit: the dwell the target needs taken as dwell_s times the worst
// parameter's load (exact for white noise, where a variance goes as 1 / dwell), plus the
// moves and settling of its schedule. Infinite unless the programme estimates exactly
// `estimated` (the start's parameters): a full-model programme that no longer sees a stand
// parameter would leave it fixed at nominal and its sigmas would not show that.
double bench_time_estimate(const Program& program, DesignModel model,
                           const std::vector<std::string>& estimated,
                           const std::array<double, kUnitParameterCount>& target,
                           const DesignSettings& settings, int times, double dwell_s) {
  const Program visited = repeated_program(program, times);
  const DesignBasis basis = design_basis(poses_of(visited), model, settings.mounting);
  if (basis.parameter_names != estimated || !first_unobservable(basis).empty())
    return std::numeric_limits<double>::infinity();
  const std::vector<double> dwells(visited.positions.size(), dwell_s);
  const TargetLoad load =
      load_of(basis, target, scheduled_information(basis, visited, settings, dwells));
  if (!(load.worst > 0)) return std::numeric_limits<double>::infinity();
  return bench_time(visited, settings,
                    std::vector<double>(visited.positions.size(), dwell_s * load.worst))
      .total_s();
}

// One round of the pattern search: each position's angles stepped by +-step, the step
// quartered from 8 degrees down to 0.125 (the stand sets angles more finely, but the bench
// time hardly moves below that).
Program polish_at(Program program, DesignModel model, const std::vector<std::string>& estimated,
                  const StandLimits& limits, const AccuracyTarget& target,
                  const DesignSettings& settings, const RevisitPlan& plan) {
  const auto t = target.sigma_internal();
  const double dwell_s = plan.equal.dwell_s.front();
  const auto estimate = [&](const Program& p) {
    return bench_time_estimate(p, model, estimated, t, settings, plan.times, dwell_s);
  };
  const auto moved = [&](double a, double by, const AxisRange& r) {
    return r.continuous ? wrap_deg(a + by) : clamp_to_range(a + by, r);
  };
  double best = estimate(program);
  for (double step = 8; step > 0.1; step /= 4) {
    bool improved = true;
    while (improved) {
      improved = false;
      for (ProgramPosition& p : program.positions)
        for (int axis = 0; axis < 2; ++axis)
          for (const double sign : {+1.0, -1.0}) {
            double& angle = axis == 0 ? p.alpha1_deg : p.alpha2_deg;
            const double old = angle;
            angle = moved(old, sign * step, axis == 0 ? limits.alpha1 : limits.alpha2);
            const double v = estimate(program);
            if (v < best * (1 - 1e-9)) {
              best = v;
              improved = true;
            } else {
              angle = old;
            }
          }
    }
  }
  return program;
}

}  // namespace

WanderPolish polish_for_wander(const Program& start, DesignModel model, const StandLimits& limits,
                               const AccuracyTarget& target, const DesignSettings& settings,
                               int max_repeats) {
  WanderPolish out;
  out.program = start;
  out.start_plan = fastest_revisit(start, model, target, settings, max_repeats);
  out.plan = out.start_plan;
  if (!settings.wander() || !out.plan) return out;
  // Each round's estimate is made at the last exact plan; a round that does not shorten the
  // exact plan (by at least 0.1 %) ends the search.
  constexpr int kMaxRounds = 4;
  const std::vector<std::string> estimated =
      design_basis(poses_of(repeated_program(start, out.plan->times)), model, settings.mounting)
          .parameter_names;
  for (int round = 0; round < kMaxRounds; ++round) {
    const Program trial =
        polish_at(out.program, model, estimated, limits, target, settings, *out.plan);
    const std::optional<RevisitPlan> plan =
        fastest_revisit(trial, model, target, settings, max_repeats);
    if (!plan || plan->time.total_s() >= out.plan->time.total_s() * (1 - 1e-3)) break;
    out.program = trial;
    out.plan = plan;
    ++out.rounds;
  }
  if (out.rounds > 0) out.program.name = start.name + "-wander";
  return out;
}

}  // namespace standcal
