#include "calib/diagnosis/residual_model.hpp"

#include <algorithm>
#include <exception>

#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

// The diagnosis models the noise itself, with the terms (wander.hpp): its fits weight as white.
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

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
  for (std::size_t j = 0; j < d.obs.kept.size(); ++j)
    row[static_cast<Eigen::Index>(j)] = J(axis, d.obs.kept[j]);
  return row;
}

LinearProblem full_problem(const std::vector<PositionAverage>& avg, const FitResult& fit,
                           const FullDesign& d) {
  LinearProblem lp;
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
      for (std::size_t j = 0; j < d.obs.kept.size(); ++j)
        lp.A(r, static_cast<Eigen::Index>(j)) = J(a, d.obs.kept[j]) / s;
      lp.row_sigma_g.push_back(s);
      lp.row_position.push_back(static_cast<int>(k));
      lp.row_component.push_back(a);
      lp.noise_rows.push_back(noise_row(avg[k], Vec3::Unit(a), s));
    }
  }
  lp.unit_column.assign(kUnitParameterCount, -1);
  for (std::size_t j = 0; j < d.obs.kept.size(); ++j)
    if (d.obs.kept[j] < kUnitParameterCount)
      lp.unit_column[static_cast<std::size_t>(d.obs.kept[j])] = static_cast<int>(j);
  lp.y_white = lp.y;
  lp.A_white = lp.A;
  return lp;
}

LinearProblem invariant_problem(const std::vector<PositionAverage>& avg, const FitResult& fit) {
  LinearProblem lp;
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
    lp.row_component.push_back(0);
    lp.noise_rows.push_back(noise_row(avg[k], avg[k].up(), s));
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
  for (std::size_t j = 0; j < keep.size(); ++j)
    lp.A.col(static_cast<Eigen::Index>(j)) = A.col(keep[j]);
  lp.y_white = lp.y;
  lp.A_white = lp.A;
  return lp;
}

// All three components of J (model.md, "Full measurement model").
class FullVectorModel : public ResidualModel {
 public:
  FullVectorModel(const std::vector<PositionAverage>& avg, FitResult fit, FullDesign design)
      : design_(std::move(design)) {
    fit_ = std::move(fit);
    lp_ = full_problem(avg, fit_, design_);
  }
  std::string name() const override { return "full"; }
  std::string words() const override { return "full-vector"; }
  int rows_per_position() const override { return 3; }
  std::string component_name(int c) const override { return kAxisNames[c]; }
  std::string component_words(int c) const override {
    return std::string(kAxisNames[c]) + " output";
  }
  std::string unseen_reason(const CatalogEntry&) const override { return ""; }
  MatrixXd project(const MatrixXd& effect_g, const PositionContext&) const override {
    return effect_g;
  }
  MatrixXd pose_rows(const StandPose& pose, double sigma_g) const override {
    MatrixXd rows(3, lp_.A.cols());
    for (int a = 0; a < 3; ++a) rows.row(a) = full_design_row(design_, pose, a) / sigma_g;
    return rows;
  }
  std::unique_ptr<ResidualModel> refit(
      const std::vector<PositionAverage>& corrected) const override {
    return std::make_unique<FullVectorModel>(
        corrected, fit_full_vector(corrected, white_noise_weighting()), design_);
  }

 private:
  FullDesign design_;
};

// The paper's invariant measurement delta_J_L = u^T J - 1 (model.md eq. 22).
class InvariantModel : public ResidualModel {
 public:
  InvariantModel(const std::vector<PositionAverage>& avg, FitResult fit) {
    fit_ = std::move(fit);
    lp_ = invariant_problem(avg, fit_);
  }
  std::string name() const override { return "joint"; }
  std::string words() const override { return "invariant"; }
  int rows_per_position() const override { return 1; }
  std::string component_name(int) const override { return "L"; }
  std::string component_words(int) const override { return "invariant projection"; }
  std::string unseen_reason(const CatalogEntry& entry) const override {
    if (entry.invariant_visible) return "";
    return "the invariant projection cannot see it (it turns the measured vector, which u^T J "
           "ignores to first order); a programme with redundancy for the full-vector fit would";
  }
  MatrixXd project(const MatrixXd& effect_g, const PositionContext& p) const override {
    return p.up.transpose() * effect_g;
  }
  MatrixXd pose_rows(const StandPose& pose, double sigma_g) const override {
    const Eigen::Matrix<double, 1, 9> reg = invariant_regressor(
        up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad, pose.mount));
    MatrixXd row = MatrixXd::Zero(1, lp_.A.cols());
    for (int j = 0; j < kUnitParameterCount; ++j)
      if (lp_.unit_column[static_cast<std::size_t>(j)] >= 0)
        row(0, lp_.unit_column[static_cast<std::size_t>(j)]) = reg[j] / sigma_g;
    return row;
  }
  std::unique_ptr<ResidualModel> refit(
      const std::vector<PositionAverage>& corrected) const override {
    return std::make_unique<InvariantModel>(
        corrected, fit_invariant_joint(corrected, white_noise_weighting()));
  }
};

// An attitude-free recording's |f| - g: the invariant projection on the measured direction
// of each interval (norm_estimator.hpp), so it sees what the invariant sees of the unit, and
// nothing of a stand: the unit was placed, not driven.
class NormModel : public InvariantModel {
 public:
  using InvariantModel::InvariantModel;
  std::string name() const override { return "norm"; }
  std::string words() const override { return "attitude-free |f| - g"; }
  std::string component_words(int) const override { return "norm residual"; }
  std::string unseen_reason(const CatalogEntry& entry) const override {
    if (entry.axes == CatalogAxes::stand_axis || entry.axes == CatalogAxes::level_axis ||
        std::string_view(entry.id) == "hysteresis")
      return "a recording without angles has no stand: no angle sensor, level or approach "
             "direction to be wrong";
    return InvariantModel::unseen_reason(entry);
  }
  std::unique_ptr<ResidualModel> refit(
      const std::vector<PositionAverage>& corrected) const override {
    return std::make_unique<NormModel>(corrected,
                                       fit_invariant_joint(corrected, white_noise_weighting()));
  }
};

// The invariant baseline, or why there is none.
FitResult invariant_baseline(const std::vector<PositionAverage>& avg) {
  try {
    return fit_invariant_joint(avg, white_noise_weighting());
  } catch (const CannotFit& e) {
    throw CannotFit("cannot check the model: " + positions_for_unknowns(avg, kUnitParameterCount) +
                    ", and not even the calibration can be fitted (" + e.what() + ")");
  }
}

}  // namespace

std::unique_ptr<ResidualModel> choose_residual_model(const std::vector<PositionAverage>& avg,
                                                     bool attitude_free) {
  if (attitude_free) return std::make_unique<NormModel>(avg, invariant_baseline(avg));
  try {
    FitResult full = fit_full_vector(avg, white_noise_weighting());
    if (full.redundancy > 0)
      return std::make_unique<FullVectorModel>(avg, std::move(full), full_design(avg));
  } catch (const std::exception&) {
    // no full-vector fit: the invariant projection below
  }
  return std::make_unique<InvariantModel>(avg, invariant_baseline(avg));
}

MatrixXd candidate_rows(const ResidualModel& model, const Candidate& c, const PositionContext& p,
                        double sigma_g) {
  return model.project(candidate_effect_g(c, p), p) / sigma_g;
}

MatrixXd decorrelated(const LinearProblem& lp, const MatrixXd& whitened) {
  return lp.noise.white() ? whitened : decorrelate(lp.noise_rows, lp.noise, whitened);
}

void ResidualModel::use_noise(const GaussMarkovNoise& noise) {
  lp_.noise = noise;
  lp_.y = decorrelated(lp_, lp_.y_white);
  lp_.A = decorrelated(lp_, lp_.A_white);
}

MatrixXd candidate_columns(const Candidate& c, const ResidualModel& model,
                           const std::vector<PositionContext>& ctx, bool white_only) {
  const LinearProblem& lp = model.problem();
  MatrixXd cols(lp.y.size(), c.params());
  for (Eigen::Index r = 0; r < cols.rows(); ++r) {
    const auto row = static_cast<std::size_t>(r);
    const PositionContext& p = ctx[static_cast<std::size_t>(lp.row_position[row])];
    cols.row(r) = candidate_rows(model, c, p, lp.row_sigma_g[row]).row(lp.row_component[row]);
  }
  return white_only ? cols : decorrelated(lp, cols);
}

std::vector<VectorXd> term_columns_white(const ResidualModel& model,
                                         const std::vector<PositionContext>& ctx,
                                         const std::vector<Candidate>& terms) {
  std::vector<VectorXd> cols;
  for (const Candidate& c : terms) {
    const MatrixXd m = candidate_columns(c, model, ctx, /*white_only=*/true);
    for (Eigen::Index j = 0; j < m.cols(); ++j) cols.push_back(m.col(j));
  }
  return cols;
}

MatrixXd all_candidate_columns(const std::vector<Candidate>& cands, const ResidualModel& model,
                               const std::vector<PositionContext>& ctx) {
  Eigen::Index total = 0;
  for (const Candidate& c : cands) total += c.params();
  MatrixXd C(model.problem().A.rows(), total);
  Eigen::Index j = 0;
  for (const Candidate& c : cands) {
    C.middleCols(j, c.params()) = candidate_columns(c, model, ctx);
    j += c.params();
  }
  return C;
}

}  // namespace standcal::diagnosis
