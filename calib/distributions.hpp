#pragma once
// Tail probabilities of the distributions the verdicts use, exact (Boost.Math): a
// consistency verdict at p < 0.05 must reject 5 % of consistent fits, not 4.7 %.

namespace standcal {

// P(X > chi2) for X ~ χ² with `dof` degrees of freedom: the regularised upper incomplete
// gamma Q(dof/2, chi2/2). NaN for dof <= 0 or a chi2 that is NaN or negative.
double chi_square_upper_tail(double chi2, int dof);

// Student's t quantile of a two-sided 95 % interval, t_0.975(ν), for real ν (the
// Welch–Satterthwaite ν_eff is rarely whole): exact, GUM Table G.2's values to all
// digits. ν < 1 is taken as 1 (GUM G.6.4 allows no fewer); ν = ∞ (or NaN) gives the
// normal quantile 1.959964.
double student_t_975(double dof);

}  // namespace standcal
