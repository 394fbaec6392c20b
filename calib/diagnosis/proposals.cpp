#include "calib/diagnosis/proposals.hpp"

#include <algorithm>
#include <cmath>

#include "calib/diagnosis/words.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kProposalStep_deg = 30;

// Candidate poses for proposals: only where the stand can go, every 30 deg of each axis's
// range (programme design's grid, calib/programs axis_grid_deg).
std::vector<ProposedPosition> grid_poses(const StandLimits& limits) {
  std::vector<ProposedPosition> out;
  for (double a1 : axis_grid_deg(limits.alpha1, kProposalStep_deg))
    for (double a2 : axis_grid_deg(limits.alpha2, kProposalStep_deg))
      out.push_back({a1, a2, 0, ""});
  return out;
}

// A pose visited after the recording: later in time (one dwell and move each), at the
// last temperature, approached alternately from both sides.
PositionContext future_context(const StandPose& pose, const std::vector<PositionContext>& ctx,
                               int step) {
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

}  // namespace

std::vector<ProposedPosition> propose_for_redundancy(const ResidualModel& model,
                                                     const std::vector<PositionContext>& ctx,
                                                     const std::vector<Candidate>& cands,
                                                     Mount mount, const StandLimits& limits) {
  const double s = median_sigma(model.problem());
  MatrixXd A = model.problem().A;
  MatrixXd C = all_candidate_columns(cands, model, ctx);
  std::vector<ProposedPosition> chosen;
  for (int step = 0; step < 6; ++step) {
    double best_score = -1;
    ProposedPosition best;
    MatrixXd best_A, best_C;
    for (const ProposedPosition& g : grid_poses(limits)) {
      const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
      const MatrixXd rows = model.pose_rows(pose, s);
      const PositionContext pc = future_context(pose, ctx, step);
      MatrixXd A2(A.rows() + rows.rows(), A.cols());
      A2 << A, rows;
      MatrixXd C2(C.rows() + rows.rows(), C.cols());
      C2.topRows(C.rows()) = C;
      Eigen::Index j = 0;
      for (const Candidate& c : cands) {
        C2.block(C.rows(), j, rows.rows(), c.params()) = candidate_rows(model, c, pc, s);
        j += c.params();
      }
      const double score = unabsorbed_fractions(A2, C2).sum();
      if (score > best_score) {
        best_score = score;
        best = g;
        best_A = A2;
        best_C = C2;
      }
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

Discrimination propose_discriminating(const ResidualModel& model,
                                      const std::vector<PositionContext>& ctx,
                                      const Selection& selection, const Rivals& rivals, Mount mount,
                                      const StandLimits& limits) {
  const LinearProblem& lp = model.problem();
  const double s = median_sigma(lp);
  const std::vector<Candidate> chosen = selection.chosen_candidates();
  auto fit_with = [&](const Candidate& c) {
    std::vector<VectorXd> cols = selection.chosen_cols;
    const MatrixXd extra = candidate_columns(c, model, ctx);
    for (Eigen::Index j = 0; j < extra.cols(); ++j) cols.push_back(extra.col(j));
    return solve_linear(with_columns(lp.A, cols), lp.y, lp.row_position, lp.positions).beta;
  };
  const Candidate& c1 = rivals.best_cand;
  const Candidate& c2 = rivals.rival_cand;
  const VectorXd b1 = fit_with(c1), b2 = fit_with(c2);
  std::vector<ProposedPosition> scored;
  for (ProposedPosition g : grid_poses(limits)) {
    const StandPose pose{g.alpha1_deg, g.alpha2_deg, mount};
    const PositionContext pc = future_context(pose, ctx, 0);
    const MatrixXd rows = model.pose_rows(pose, s);
    auto predict = [&](const VectorXd& beta, const Candidate& extra) {
      VectorXd pred = rows * beta.head(lp.A.cols());
      Eigen::Index j = lp.A.cols();
      for (const Candidate& c : chosen) {
        pred += candidate_rows(model, c, pc, s) * beta.segment(j, c.params());
        j += c.params();
      }
      pred += candidate_rows(model, extra, pc, s) * beta.segment(j, extra.params());
      return pred;
    };
    g.predicted_difference_sigma = (predict(b1, c1) - predict(b2, c2)).norm();
    g.why = "the two explanations predict means " + fmt("%.1f", g.predicted_difference_sigma) +
            " sigma apart";
    scored.push_back(g);
  }
  std::sort(scored.begin(), scored.end(), [](const ProposedPosition& a, const ProposedPosition& b) {
    return a.predicted_difference_sigma > b.predicted_difference_sigma;
  });
  Discrimination d;
  if (scored.empty()) return d;
  const double best = scored.front().predicted_difference_sigma;
  const double worst = scored.back().predicted_difference_sigma;
  if (scored.size() > 4) scored.resize(4);
  // The rivals differ in time or temperature, not in angle: every pose predicts the same
  // difference, and the best few differ by less than a sigma.
  d.no_pose_separates =
      best - scored.back().predicted_difference_sigma < 1 && best - worst < 0.1 * best;
  if (!d.no_pose_separates) d.positions = scored;
  return d;
}

}  // namespace standcal::diagnosis
