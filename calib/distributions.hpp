#pragma once
// Tail probabilities of the distributions the verdicts use, exact (Boost.Math): a
// consistency verdict at p < 0.05 must reject 5 % of consistent fits, not 4.7 %.

namespace standcal {

// P(X > chi2) for X ~ χ² with `dof` degrees of freedom: the regularised upper incomplete
// gamma Q(dof/2, chi2/2). NaN for dof <= 0 or a chi2 that is NaN or negative.
double chi_square_upper_tail(double chi2, int dof);

}  // namespace standcal
