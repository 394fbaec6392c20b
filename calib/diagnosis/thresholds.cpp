// discrimination_thresholds (diagnosis.hpp, docs/diagnosis.md "Discrimination threshold").
#include <limits>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/mounting.hpp"
#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/settling.hpp"

namespace standcal {

namespace {

using Eigen::MatrixXd;
constexpr double kStandOut = 3;  // sigma

// Smallest singular value of the part of C that [A, competitor] cannot explain.
double unexplained_size(const MatrixXd& A, const MatrixXd& C, const MatrixXd* competitor) {
  MatrixXd M(A.rows(), A.cols() + (competitor ? competitor->cols() : 0));
  M.leftCols(A.cols()) = A;
  if (competitor) M.rightCols(competitor->cols()) = *competitor;
  const MatrixXd rest = diagnosis::unexplained_part(M, C);
  return rest.size() == 0 ? 0.0 : Eigen::JacobiSVD<MatrixXd>(rest).singularValues().minCoeff();
}

// Column candidates: 3 / s_min against the noise and against each testable competitor.
std::vector<DiscriminationThreshold> column_thresholds(const diagnosis::Prepared& P) {
  const MatrixXd& A = P.model->problem().A;
  std::vector<MatrixXd> cols;
  for (const diagnosis::Candidate& c : P.cands)
    cols.push_back(diagnosis::candidate_columns(c, *P.model, P.ctx));
  std::vector<DiscriminationThreshold> out;
  for (std::size_t i = 0; i < P.cands.size(); ++i) {
    if (!P.untestable[i].empty()) continue;
    DiscriminationThreshold t{
        P.cands[i].effect(), P.cands[i].axis, P.cands[i].unit(), 0, 0, "noise"};
    double smallest = unexplained_size(A, cols[i], nullptr);
    for (std::size_t k = 0; k < P.cands.size(); ++k) {
      if (k == i || !P.untestable[k].empty()) continue;
      const double s = unexplained_size(A, cols[i], &cols[k]);
      if (s < smallest) {
        smallest = s;
        t.nearest = P.cands[k].effect() + " " + P.cands[k].axis;
      }
    }
    t.threshold = smallest > 0 ? kStandOut / smallest : std::numeric_limits<double>::infinity();
    out.push_back(t);
  }
  return out;
}

}  // namespace

std::vector<DiscriminationThreshold> discrimination_thresholds(const Recording& reference,
                                                               const DiagnoseOptions& options) {
  const diagnosis::Prepared P = diagnosis::prepare(reference, options);
  std::vector<DiscriminationThreshold> out = column_thresholds(P);
  for (int a = 0; a < 3; ++a)
    for (double tau : options.settling_tau_grid_s) {
      const diagnosis::SettlingResult r = diagnosis::settling_search(reference, P.avg, a, tau);
      // Standing out is a matter of the test at the best tau (sigma with tau known); the
      // reported sigma of a finding is the wider one with tau free.
      out.push_back({"settling_transient", diagnosis::kAxisNames[a], "ug", tau,
                     kStandOut * r.sigma_ug, "noise"});
    }
  if (P.model->sees(diagnosis::catalog_entry("mounting_misalignment_large"))) {
    const diagnosis::MountingEstimate m = diagnosis::mounting_estimate(P.model->fit());
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(m.sigma_arcmin[a]))
        out.push_back({"mounting_misalignment_large", diagnosis::kAxisNames[a], "arcmin", 0,
                       options.mounting_tolerance_arcmin + kStandOut * m.sigma_arcmin[a],
                       "fixture tolerance"});
  }
  return out;
}

}  // namespace standcal
