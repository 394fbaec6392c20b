// discrimination_thresholds (diagnosis.hpp, docs/diagnosis.md "Discrimination threshold").
#include <cmath>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/mounting.hpp"
#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/settling.hpp"

namespace standcal {

namespace {

using diagnosis::kStandOut_sigma;
using Eigen::MatrixXd;

// Sigma of the term C when the baseline A and (if given) a competitor are fitted too.
double sigma_besides(const MatrixXd& A, const MatrixXd& C, const MatrixXd* competitor) {
  MatrixXd M(A.rows(), A.cols() + (competitor ? competitor->cols() : 0));
  M.leftCols(A.cols()) = A;
  if (competitor) M.rightCols(competitor->cols()) = *competitor;
  return diagnosis::term_sigma(diagnosis::unexplained_part(M, C));
}

// Column candidates: 3 sigma against the noise and against each testable competitor.
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
    double largest_sigma = sigma_besides(A, cols[i], nullptr);
    for (std::size_t k = 0; k < P.cands.size(); ++k) {
      if (k == i || !P.untestable[k].empty()) continue;
      const double sigma = sigma_besides(A, cols[i], &cols[k]);
      if (sigma > largest_sigma) {
        largest_sigma = sigma;
        t.nearest = P.cands[k].effect() + " " + P.cands[k].axis;
      }
    }
    t.threshold = kStandOut_sigma * largest_sigma;
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
                     kStandOut_sigma * r.sigma_ug, "noise"});
    }
  if (P.model->sees(diagnosis::catalog_entry("mounting_misalignment_large"))) {
    const diagnosis::MountingEstimate m = diagnosis::mounting_estimate(P.model->fit());
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(m.sigma_arcmin[a]))
        out.push_back({"mounting_misalignment_large", diagnosis::kAxisNames[a], "arcmin", 0,
                       options.mounting_tolerance_arcmin + kStandOut_sigma * m.sigma_arcmin[a],
                       "fixture tolerance"});
  }
  return out;
}

}  // namespace standcal
