#include "calib/distributions.hpp"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>

namespace standcal {

double chi_square_upper_tail(double chi2, int dof) {
  if (dof <= 0 || !(chi2 >= 0)) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(chi2)) return 0.0;
  return boost::math::gamma_q(0.5 * dof, 0.5 * chi2);
}

double student_t_975(double dof) {
  constexpr double p = 0.975;
  if (!(dof < 1e12)) return boost::math::quantile(boost::math::normal_distribution<double>(), p);
  return boost::math::quantile(boost::math::students_t_distribution<double>(std::max(dof, 1.0)), p);
}

}  // namespace standcal
