#include "calib/distributions.hpp"

#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>

namespace standcal {

double chi_square_upper_tail(double chi2, int dof) {
  if (dof <= 0 || !(chi2 >= 0)) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(chi2)) return 0.0;
  return boost::math::gamma_q(0.5 * dof, 0.5 * chi2);
}

}  // namespace standcal
