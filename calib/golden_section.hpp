#pragma once
// Golden-section search for the maximum of a unimodal function of one variable, for the
// searches that refine a grid (the settling transient's tau, the wander's q).
#include <cmath>
#include <utility>

namespace standcal {

// Maximises eval on [lo, hi] with `iterations` narrowing steps (each one evaluation);
// `better(a, b)` says whether result a beats result b. Returns the best point evaluated
// and its result.
template <class Eval, class Better>
auto golden_section_max(const Eval& eval, double lo, double hi, int iterations,
                        const Better& better) {
  const double phi = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
  auto r1 = eval(x1), r2 = eval(x2);
  for (int it = 0; it < iterations; ++it) {
    if (better(r1, r2)) {
      hi = x2;
      x2 = x1;
      r2 = r1;
      x1 = hi - phi * (hi - lo);
      r1 = eval(x1);
    } else {
      lo = x1;
      x1 = x2;
      r1 = r2;
      x2 = lo + phi * (hi - lo);
      r2 = eval(x2);
    }
  }
  return better(r1, r2) ? std::pair{x1, r1} : std::pair{x2, r2};
}

}  // namespace standcal
