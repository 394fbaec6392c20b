#pragma once
// Honesty outside the catalog (issue 15, docs/diagnosis.md "Checks before explained"):
// before the diagnosis says `explained`, what its chosen terms leave must look like
// noise. A term from the catalog can lower chi2 to about its degrees of freedom and
// still leave a pattern that no noise makes: residuals that keep their sign over a run
// of consecutive positions in time, or along an angle or a gravity component, or that
// step once mid-run. These checks do not know the catalog: they see only the residuals.
#include <string>
#include <vector>

#include "calib/model.hpp"

namespace standcal::diagnosis {

// One normalised residual (residual / its standard error) of the model being checked.
struct ResidualSample {
  int position = 0;       // index of the position in the recording
  int pos_label = 0;      // the recording's position number, for words
  std::string component;  // "x", "y", "z" (full vector) or "L" (invariant projection)
  double t_s = 0;         // mid-time of the dwell
  double alpha1_deg = 0, alpha2_deg = 0;
  Vec3 up = Vec3::Zero();  // gravity direction in instrument axes (model.md's u)
  double r = 0;
};

// One test of one component's residuals against one ordering variable.
struct WhitenessTest {
  std::string component;  // "x", "y", "z" or "L"
  std::string against;    // "time", "alpha1", "alpha2", "u_x", "u_y", "u_z"
  std::string test;       // "serial" (neighbours agree), "step" (a level shift, CUSUM), "outlier"
  int n = 0;
  double statistic = 0;  // serial: z of the lag-one correlation; step: Kolmogorov D * sqrt(n)
  double p = 1;          // one-sided P(at least this much structure | white residuals)
  // Where the pattern is strongest: the longest run of one sign (serial), or the part
  // after the step (step), as positions and a time span.
  std::vector<int> positions;
  double t_from_s = 0, t_to_s = 0;
};

struct WhitenessResult {
  std::vector<WhitenessTest> tests;
  // Bonferroni over every test made: residuals count as white when no test's p falls
  // below family_alpha / tests.size().
  double family_alpha = 1e-3;
  bool white = true;
  int worst = -1;  // index into tests of the smallest p, or -1 when nothing was testable
};

// Serial-correlation tests of each component's residuals ordered by time, by each stand
// angle and by each gravity component, and a step test in time. A component with fewer
// than 8 residuals is not tested (the tests' normal approximations need them). And the
// largest residual of each component against the largest of that many normal ones.
WhitenessResult whiteness_tests(const std::vector<ResidualSample>& residuals,
                                double family_alpha = 1e-3);

// The failed test in words: which output, against what, where.
std::string whiteness_words(const WhitenessTest& t);

// A chosen term's value fitted on the first and on the second half of the run (in time)
// against its value on the whole run. A real effect of the kind the term describes gives
// the same value on each half; a term that only happens to fit (a drift standing in for a
// jump, a temperature coefficient standing in for wander) does not.
struct HalfStability {
  std::string effect, axis, unit;
  double value_all = 0, sigma_all = 0;
  double value_first = 0, sigma_first = 0;
  double value_second = 0, sigma_second = 0;
  double z = 0;  // the larger |half - whole| / sqrt(sigma_half^2 - sigma_whole^2)
  bool stable = true;
};

// z of one half against the whole. The whole contains the half, so their difference has
// variance sigma_half^2 - sigma_whole^2 (the whole is the half's estimate updated by
// independent data); floored at a tenth of sigma_half^2 for halves that carry the fit.
double half_against_whole_z(double value_half, double sigma_half, double value_all,
                            double sigma_all);

// Fills z and stable (|z| <= z_limit on both halves; a half that cannot fit the term
// does not count as unstable).
void judge_half_stability(HalfStability& h, double z_limit);

}  // namespace standcal::diagnosis
