#pragma once
// mounting_misalignment_large (docs/diagnosis.md step 4): the full-vector baseline fits the
// mounting with exact rotations, so what matters is its size, which the paper's invariant
// method absorbs silently (model.md).
#include <string>
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/fit_result.hpp"

namespace standcal::diagnosis {

// The fitted mounting misalignment about each instrument axis (arcmin, with sigma) from
// the full-vector fit's stand estimates; NaN where the fit has none.
struct MountingEstimate {
  double value_arcmin[3] = {kNaN, kNaN, kNaN};
  double sigma_arcmin[3] = {kNaN, kNaN, kNaN};
  std::string combination[3];
};
MountingEstimate mounting_estimate(const FitResult& fit);

// The mounting angle about each axis against the fixture tolerance. It is a parameter of
// the full-vector baseline (which models it exactly), so this is a test of its size, not a
// new term: chi2 gain = ((|psi| - tolerance) / sigma)^2.
std::vector<CandidateTest> mounting_tests(const FitResult& fit, double chi2_dof, std::size_t n_rows,
                                          const DiagnoseOptions& options);

// A significant large mounting, in words: what the invariant method would get wrong.
Finding mounting_finding(const CandidateTest& t, const MountingEstimate& m, double chi2_dof,
                         const DiagnoseOptions& options);

// Why the mounting is not tested when the residual model cannot see it.
std::string mounting_not_tested_words();

}  // namespace standcal::diagnosis
