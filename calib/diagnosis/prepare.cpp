#include "calib/diagnosis/prepare.hpp"

#include <cmath>

#include "calib/averaging.hpp"
#include "calib/identifiability.hpp"

namespace standcal::diagnosis {

namespace {

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
        throw CannotFit("cannot check the model: the " + std::to_string(p.samples) +
                        " samples of position " + std::to_string(p.pos) + " do not vary on axis " +
                        kAxisNames[a] +
                        " (zero variance), so their noise is unknown; are the readings stuck, or "
                        "quantised coarser than the noise?");
}

// Temperature terms are referenced to the recording's temp_ref_c, else its first reading.
double temperature_reference_c(const Recording& rec) {
  if (rec.temp_ref_c) return *rec.temp_ref_c;
  for (const auto& s : rec.samples)
    if (std::isfinite(s.temp_c)) return s.temp_c;
  return 0;
}

struct Testability {
  std::string reason;        // why the candidate cannot be tested, or empty
  bool implausible = false;  // only because no plausible size would stand out
};

// Whether this programme can test a candidate: not when the residual model cannot see it;
// nor when the baseline parameters absorb it (every column must keep some of its size after
// they have absorbed what they can); nor when its sigma on this programme (white noise)
// exceeds any plausible size, so the fit could not tell a plausible value from zero, as for
// a temperature coefficient on a run whose temperature hardly changed.
Testability testability(const Candidate& c, const Prepared& P, const Eigen::VectorXd& left,
                        const Eigen::MatrixXd& rest, Eigen::Index first,
                        const DiagnoseOptions& options) {
  if (std::string unseen = P.model->unseen_reason(*c.entry); !unseen.empty()) return {unseen};
  if (P.base.dof <= 0 ||
      !(left.segment(first, c.params()).minCoeff() > options.min_unabsorbed_fraction))
    return {"absorbed by the calibration parameters on this programme"};
  if (!(term_sigma(rest.middleCols(first, c.params())) <=
        c.entry->typical_max * options.plausible_size_factor))
    return {std::string("too little ") + c.entry->excitation +
                " on this programme: no plausible size would stand out from the noise",
            true};
  return {};
}

void mark_testable(Prepared& P, const DiagnoseOptions& options) {
  const Eigen::MatrixXd C = all_candidate_columns(P.cands, *P.model, P.ctx);
  const Eigen::MatrixXd rest = unexplained_part(P.model->problem().A, C);
  const Eigen::VectorXd left = fractions_left(C, rest);
  Eigen::Index j = 0;
  for (const Candidate& c : P.cands) {
    const Testability t = testability(c, P, left, rest, j, options);
    P.untestable.push_back(t.reason);
    P.implausible.push_back(t.implausible);
    P.n_standing_out += t.reason.empty() || t.implausible ? 1 : 0;
    j += c.params();
  }
}

}  // namespace

Prepared prepare(const Recording& rec, const DiagnoseOptions& options) {
  Prepared P;
  AveragedRecording averaged = average_recording(rec);
  P.avg = std::move(averaged.averages);
  P.allan = std::move(averaged.allan);
  if (options.dwell_standard_error_g.size() == P.avg.size())
    for (std::size_t k = 0; k < P.avg.size(); ++k)
      P.avg[k].standard_error_g =
          P.avg[k].standard_error_g.cwiseMax(options.dwell_standard_error_g[k]);
  require_checkable(P.avg);
  for (const auto& p : P.avg) P.have_temp = P.have_temp && std::isfinite(p.temp_mean_c);
  P.temp_ref_c = temperature_reference_c(rec);
  P.ctx = position_contexts(P.avg, P.temp_ref_c);
  P.model = choose_residual_model(P.avg, options.attitude_free);
  const LinearProblem& lp = P.model->problem();
  P.base = solve_linear(lp.A, lp.y, lp.row_position, lp.positions);
  P.cands = catalog_candidates(P.have_temp);
  mark_testable(P, options);
  return P;
}

}  // namespace standcal::diagnosis
