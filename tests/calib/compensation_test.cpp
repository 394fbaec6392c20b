// The compensation file (calib/compensation.hpp): the covariance propagated from each
// estimator's parameters agrees with the Jacobian written out by hand, the JSON reads back
// to the same numbers, and the checksum rejects an edited number.
#include <gtest/gtest.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calib/compensation.hpp"
#include "calib/norm_estimator.hpp"
#include "calib/parameters.hpp"
#include "calib/raw_input.hpp"

namespace standcal {
namespace {

using Mat9 = Eigen::Matrix<double, 9, 9>;

// A covariance with correlations: A A^T of a fixed, well-conditioned A scaled per parameter.
Mat9 correlated_covariance(const Eigen::Matrix<double, 9, 1>& sigma) {
  Mat9 a = Mat9::Identity();
  for (int i = 0; i < 9; ++i)
    for (int k = 0; k < i; ++k) a(i, k) = 0.3 * std::sin(1.0 + i * 3 + k);
  Mat9 c = a * a.transpose();
  const Eigen::VectorXd d = c.diagonal().cwiseSqrt().cwiseInverse();
  c = d.asDiagonal() * c * d.asDiagonal();  // a correlation matrix
  return sigma.asDiagonal() * c * sigma.asDiagonal();
}

NormFit norm_fit_example() {
  NormFit fit;
  NormCompensation& k = fit.compensation;
  k.bias = {32768.5, 32790.1, 32701.7};  // counts
  k.scale = {414.46, 416.02, 409.87};    // counts per m/s^2
  k.misalignment = {0.0021, -0.0013, 0.0007};
  k.matrix = k.triangular() * Vec3(k.scale.cwiseInverse()).asDiagonal();
  Eigen::Matrix<double, 9, 1> sigma;
  sigma << 0.8, 0.9, 1.1, 0.05, 0.06, 0.04, 2e-4, 3e-4, 2.5e-4;
  fit.sigma = sigma;
  fit.covariance = correlated_covariance(sigma);
  return fit;
}

TEST(Compensation, NormCovarianceIsTheHandWrittenJacobianPropagated) {
  const NormFit fit = norm_fit_example();
  RawInput input;
  input.units = InputUnits::counts;
  input.source = "xsens.mat";
  const Compensation c = make_compensation(fit, input);
  EXPECT_EQ(c.input_units, "counts");
  EXPECT_TRUE(c.bias.isApprox(fit.compensation.bias));
  EXPECT_TRUE(c.matrix.isApprox(fit.compensation.matrix));

  // M_ij = T_ij / s_j; the parameters are b (0-2), s (3-5), m01, m02, m12 (6-8).
  const NormCompensation& k = fit.compensation;
  const Mat3 t = k.triangular();
  Eigen::Matrix<double, kCompensationValues, 9> j =
      Eigen::Matrix<double, kCompensationValues, 9>::Zero();
  j.topLeftCorner<3, 3>().setIdentity();
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col)
      j(3 + 3 * r + col, 3 + col) = -t(r, col) / (k.scale[col] * k.scale[col]);
  j(3 + 1, 6) = 1 / k.scale[1];      // M_12 = m01 / s_y
  j(3 + 2, 7) = 1 / k.scale[2];      // M_13 = m02 / s_z
  j(3 + 3 + 2, 8) = 1 / k.scale[2];  // M_23 = m12 / s_z
  const CompensationCovariance expected = j * fit.covariance * j.transpose();
  for (int r = 0; r < kCompensationValues; ++r)
    for (int col = 0; col < kCompensationValues; ++col) {
      const double scale = std::sqrt(expected(r, r) * expected(col, col));
      EXPECT_NEAR(c.covariance(r, col), expected(r, col), 1e-6 * scale + 1e-30) << r << "," << col;
    }
}

TEST(Compensation, StandFitCovarianceOfBiasAndScale) {
  FitResult fit;
  fit.estimator = "joint";
  const double values[9] = {200e-6, -150e-6, 80e-6, 300e-6, -200e-6, 100e-6, 1e-4, -2e-4, 3e-4};
  const double sigmas[9] = {2e-6, 3e-6, 4e-6, 5e-6, 6e-6, 7e-6, 1e-5, 2e-5, 3e-5};
  for (std::size_t i = 0; i < 9; ++i)
    fit.unit[i] = ParameterEstimate{values[i], sigmas[i], "", 1e9};
  fit.correlation = Eigen::MatrixXd::Identity(9, 9);
  const double g = 9.81625;
  const Compensation c = make_compensation(fit, g);
  // b = bias_g g exactly; M_ii = 1 / (1 + s_i) to first order in the gammas.
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(c.bias[i], values[i] * g, 1e-15);
    EXPECT_NEAR(std::sqrt(c.covariance(i, i)), sigmas[i] * g, 1e-9 * sigmas[i] * g);
    const double s = values[3 + i];
    EXPECT_NEAR(std::sqrt(c.covariance(3 + 4 * i, 3 + 4 * i)), sigmas[3 + i] / ((1 + s) * (1 + s)),
                1e-3 * sigmas[3 + i]);
  }
  // Independent parameters: b does not covary with M.
  EXPECT_EQ((c.covariance.topRightCorner<3, 9>().norm()), 0.0);
}

TEST(Compensation, StandFitWithAnUnobservableParameterSaysItAssumedZero) {
  FitResult fit;
  fit.estimator = "full";
  for (std::size_t i = 0; i < 9; ++i) fit.unit[i] = ParameterEstimate{1e-5, 1e-6, "", 1e9};
  fit.unit[8] = ParameterEstimate{};
  fit.unit[8].unobservable_reason = "no position tilts y and z together";
  fit.correlation = Eigen::MatrixXd::Identity(9, 9);
  // As the estimators report an unobservable parameter: NaN across its row and column.
  fit.correlation.row(8).setConstant(std::numeric_limits<double>::quiet_NaN());
  fit.correlation.col(8).setConstant(std::numeric_limits<double>::quiet_NaN());
  const Compensation c = make_compensation(fit, kStandardGravity_mps2);
  ASSERT_FALSE(c.notes.empty());
  EXPECT_NE(c.notes[0].find("gamma23 was not observable"), std::string::npos) << c.notes[0];
  EXPECT_TRUE(c.covariance.allFinite());
}

Compensation example_with_identity() {
  RawInput input;
  input.units = InputUnits::counts;
  input.source = "xsens.mat";
  Compensation c = make_compensation(norm_fit_example(), input);
  c.identity.unit_serial = "AU-0042";
  c.identity.run_id = "20261203-001";
  c.identity.temperature_reference_c = 23.4;
  c.identity.temperature_how = "mean over the dwells";
  return c;
}

TEST(Compensation, JsonReadsBackToTheSameNumbersAndIdentity) {
  const Compensation c = example_with_identity();
  const nlohmann::json doc = compensation_to_json(c);
  EXPECT_EQ(doc["format"], "standcal-compensation/2");
  EXPECT_EQ(doc["unit"]["type"], nullptr);
  const Compensation back = compensation_from_json(nlohmann::json::parse(doc.dump()));
  EXPECT_EQ(back.bias, c.bias);
  EXPECT_EQ(back.matrix, c.matrix);
  EXPECT_EQ(back.covariance, c.covariance);
  EXPECT_EQ(back.identity.unit_serial, "AU-0042");
  EXPECT_EQ(back.identity.run_id, "20261203-001");
  EXPECT_EQ(back.identity.source, "xsens.mat");
  EXPECT_DOUBLE_EQ(*back.identity.temperature_reference_c, 23.4);
  EXPECT_EQ(back.input_units, "counts");
  EXPECT_EQ(back.estimator, "norm");
  EXPECT_EQ(back.written_utc, doc["written"]["utc"]);
  EXPECT_EQ(compensation_to_json(back), doc);  // written again unchanged
}

TEST(Compensation, AnEditedNumberOrAMissingFieldIsRefusedByName) {
  const nlohmann::json doc = compensation_to_json(example_with_identity());
  nlohmann::json edited = doc;
  edited["matrix"]["rows"][2][2] = doc["matrix"]["rows"][2][2].get<double>() + 1e-12;
  EXPECT_THROW(
      {
        try {
          (void)compensation_from_json(edited);
        } catch (const CompensationError& e) {
          EXPECT_NE(std::string(e.what()).find("the file was damaged or edited"), std::string::npos)
              << e.what();
          throw;
        }
      },
      CompensationError);
  nlohmann::json missing = doc;
  missing["bias"].erase("values");
  try {
    (void)compensation_from_json(missing);
    ADD_FAILURE() << "accepted without bias.values";
  } catch (const CompensationError& e) {
    EXPECT_NE(std::string(e.what()).find("not a valid standcal-compensation/2 document"),
              std::string::npos)
        << e.what();
  }
  nlohmann::json other = doc;
  other["format"] = "standcal-compensation/1";
  EXPECT_THROW((void)compensation_from_json(other), CompensationError);
}

// The CSV's numbers, read back as a C loader reads them (strtod), give the stated checksum.
TEST(Compensation, CsvNumbersReproduceTheChecksum) {
  const Compensation c = example_with_identity();
  const std::string csv = compensation_to_csv(c);
  EXPECT_NE(csv.find("# unit_serial: AU-0042\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("# temperature_reference_c: 23.40\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("# checksum_crc32: " + compensation_checksum(c) + "\n"), std::string::npos)
      << csv;
  Compensation parsed;
  parsed.input_units = "counts";  // the "# raw_units:" line
  EXPECT_NE(csv.find("# raw_units: counts\n"), std::string::npos) << csv;
  std::istringstream lines(csv);
  std::string line;
  int rows = 0;
  while (std::getline(lines, line)) {
    if (line.starts_with("#") || line.starts_with("name,")) continue;
    const char* p = line.c_str() + line.find(',');
    Vec3 v;
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      v[k] = std::strtod(p + 1, &end);
      p = end;
    }
    if (rows == 0)
      parsed.bias = v;
    else
      parsed.matrix.row(rows - 1) = v.transpose();
    ++rows;
  }
  ASSERT_EQ(rows, 4);
  EXPECT_EQ(compensation_checksum(parsed), compensation_checksum(c));
  parsed.input_units = "m/s^2";  // the same numbers for other units: another checksum
  EXPECT_NE(compensation_checksum(parsed), compensation_checksum(c));
}

}  // namespace
}  // namespace standcal
