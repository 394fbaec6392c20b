// The chi2 tails of the harness's ideal test (bench/diagnosis/ideal_test): central tails
// against table values, the non-central tail against closed forms, a numerical integral of
// its density and published power figures.
#include <gtest/gtest.h>

#include <cmath>

#include "bench/diagnosis/ideal_test.hpp"

namespace standcal::bench {
namespace {

TEST(Chi2Tail, MatchesTableValues) {
  EXPECT_NEAR(chi2_tail(3.841459, 1), 0.05, 1e-6);
  EXPECT_NEAR(chi2_tail(5.991465, 2), 0.05, 1e-6);
  EXPECT_NEAR(chi2_tail(7.814728, 3), 0.05, 1e-6);
  EXPECT_NEAR(chi2_tail(18.307038, 10), 0.05, 1e-6);
  EXPECT_NEAR(chi2_tail(15.086272, 5), 0.01, 1e-7);
  EXPECT_NEAR(chi2_tail(16, 1), std::erfc(std::sqrt(8.0)), 1e-15);  // 4 sigma, two-sided
  EXPECT_EQ(chi2_tail(0, 3), 1.0);
}

TEST(Chi2Tail, CriticalValueOfTwoParametersMatchesTheDiagnosis) {
  EXPECT_NEAR(critical_chi2(1, 16), 16, 1e-9);
  EXPECT_NEAR(critical_chi2(2, 16), 19.34, 0.01);  // docs/diagnosis.md: 19.3
}

// With one degree of freedom the statistic is (Z + sqrt(lambda))^2.
TEST(NoncentralChi2Tail, OneDegreeIsAShiftedNormalSquared) {
  for (double lambda : {0.5, 4.0, 9.0, 25.0, 81.0})
    for (double x : {1.0, 16.0, 40.0}) {
      const double a = std::sqrt(x), m = std::sqrt(lambda);
      const double exact =
          0.5 * std::erfc((a - m) / std::sqrt(2.0)) + 0.5 * std::erfc((a + m) / std::sqrt(2.0));
      EXPECT_NEAR(noncentral_chi2_tail(x, 1, lambda), exact, 1e-12)
          << "lambda " << lambda << " x " << x;
    }
}

// Two degrees of freedom: the density 1/2 exp(-(x + lambda) / 2) I0(sqrt(lambda x)),
// integrated by Simpson's rule from the critical value.
double integrated_two_dof_tail(double c, double lambda) {
  const double top = c + 60 + 8 * lambda;
  const int n = 20000;
  const double h = (top - c) / n;
  auto pdf = [lambda](double x) {
    return 0.5 * std::exp(-(x + lambda) / 2) * std::cyl_bessel_i(0.0, std::sqrt(lambda * x));
  };
  double sum = pdf(c) + pdf(top);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4 : 2) * pdf(c + i * h);
  return sum * h / 3;
}

TEST(NoncentralChi2Tail, TwoDegreesMatchesItsIntegratedDensity) {
  for (double lambda : {1.0, 9.0, 20.0, 50.0})
    for (double c : {5.0, 19.3, 30.0})
      EXPECT_NEAR(noncentral_chi2_tail(c, 2, lambda), integrated_two_dof_tail(c, lambda), 1e-9)
          << "lambda " << lambda << " c " << c;
}

// Textbook power figures (Cohen 1988; G*Power): 80 % power at alpha 0.05 needs
// lambda = 7.85 with one degree of freedom and 9.64 with two.
TEST(NoncentralChi2Tail, PublishedPowerFigures) {
  EXPECT_NEAR(noncentral_chi2_tail(3.841459, 1, 7.849), 0.80, 0.001);
  EXPECT_NEAR(noncentral_chi2_tail(5.991465, 2, 9.635), 0.80, 0.002);
}

TEST(NoncentralChi2Tail, EndsAndMonotony) {
  EXPECT_DOUBLE_EQ(noncentral_chi2_tail(16, 1, 0), chi2_tail(16, 1));
  EXPECT_NEAR(noncentral_chi2_tail(16, 1, 1e4), 1.0, 1e-12);
  double previous = 0;
  for (double lambda = 0; lambda < 200; lambda += 5) {
    const double p = noncentral_chi2_tail(19.3, 2, lambda);
    EXPECT_GE(p, previous - 1e-12);  // sums of Poisson weights round near 1
    EXPECT_LE(p, 1.0);
    previous = p;
  }
}

}  // namespace
}  // namespace standcal::bench
