#include "calib/model.hpp"

#include <cmath>

namespace standcal {

std::string mount_name(Mount m) {
  switch (m) {
    case Mount::x:
      return "x";
    case Mount::y:
      return "y";
    case Mount::z:
      return "z";
  }
  return "?";
}

bool parse_mount(const std::string& text, Mount& out) {
  if (text == "x")
    out = Mount::x;
  else if (text == "y")
    out = Mount::y;
  else if (text == "z")
    out = Mount::z;
  else
    return false;
  return true;
}

Mat3 C1(double a_rad) {
  const double c = std::cos(a_rad), s = std::sin(a_rad);
  Mat3 m;
  m << c, s, 0, -s, c, 0, 0, 0, 1;
  return m;
}

Mat3 C2(double a_rad) {
  const double c = std::cos(a_rad), s = std::sin(a_rad);
  Mat3 m;
  m << 1, 0, 0, 0, c, -s, 0, s, c;
  return m;
}

Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Mat3 rotation_exp(const Vec3& theta_rad) {
  const double angle = theta_rad.norm();
  if (angle < 1e-300) return Mat3::Identity();
  const Mat3 k = cross_matrix(theta_rad / angle);
  // exp(-[theta x]) = I - sin|theta| [k x] + (1 - cos|theta|) [k x]^2 (Rodrigues).
  return Mat3::Identity() - std::sin(angle) * k + (1.0 - std::cos(angle)) * k * k;
}

Vec3 up_vector_table(double alpha1_rad, double alpha2_rad) {
  return {std::sin(alpha1_rad), std::cos(alpha1_rad) * std::cos(alpha2_rad),
          std::cos(alpha1_rad) * std::sin(alpha2_rad)};
}

Mat3 mount_permutation(Mount m) {
  Mat3 p = Mat3::Zero();
  switch (m) {
    case Mount::x:
      p.setIdentity();
      break;
    case Mount::y:
      p(0, 2) = 1;
      p(1, 0) = 1;
      p(2, 1) = 1;
      break;
    case Mount::z:
      p(0, 1) = 1;
      p(1, 2) = 1;
      p(2, 0) = 1;
      break;
  }
  return p;
}

Vec3 up_vector(double alpha1_rad, double alpha2_rad, Mount m) {
  return mount_permutation(m) * up_vector_table(alpha1_rad, alpha2_rad);
}

UnitErrors UnitErrors::from_parameters(const Eigen::Matrix<double, 9, 1>& p) {
  UnitErrors u;
  u.bias_g = p.head<3>();
  u.scale = p.segment<3>(3);
  u.set_gamma_pair_sums_rad(p.tail<3>());
  return u;
}

Vec3 UnitErrors::gamma_pair_sums_rad() const {
  return {gamma_rad(0, 1) + gamma_rad(1, 0), gamma_rad(0, 2) + gamma_rad(2, 0),
          gamma_rad(1, 2) + gamma_rad(2, 1)};
}

void UnitErrors::set_gamma_pair_sums_rad(const Vec3& sums) {
  gamma_rad.setZero();
  gamma_rad(0, 1) = gamma_rad(1, 0) = sums[0] / 2;
  gamma_rad(0, 2) = gamma_rad(2, 0) = sums[1] / 2;
  gamma_rad(1, 2) = gamma_rad(2, 1) = sums[2] / 2;
}

Mat3 UnitErrors::output_matrix() const {
  return (Mat3::Identity() + Mat3(scale.asDiagonal())) * (Mat3::Identity() + gamma_rad);
}

Vec3 true_up_vector(double alpha1_rad, double alpha2_rad, Mount m, const StandErrors& s) {
  const double a1 = alpha1_rad + s.alpha1_offset_rad + s.alpha1_scale * alpha1_rad;
  const double a2 = alpha2_rad + s.alpha2_offset_rad + s.alpha2_scale * alpha2_rad;
  const Mat3 C_eps = rotation_exp(Vec3(s.levelling_x_rad, 0, s.levelling_z_rad));
  const Mat3 C_n = rotation_exp(Vec3(0, s.skew_y_rad, s.skew_z_rad));
  const Mat3 C_psi = rotation_exp(s.mounting_rad[static_cast<int>(m)]);
  return C_psi * mount_permutation(m) * C2(a2) * C_n * C1(a1) * C_eps * Vec3::UnitY();
}

Vec3 unit_output_g(const UnitErrors& unit, const Vec3& u_true) {
  return unit.bias_g + unit.output_matrix() * u_true;
}

double delta_J_L(const Vec3& u, const Vec3& J) { return u.dot(J) - 1.0; }

Eigen::Matrix<double, 1, 9> invariant_regressor(const Vec3& u) {
  Eigen::Matrix<double, 1, 9> h;
  h << u.x(), u.y(), u.z(), u.x() * u.x(), u.y() * u.y(), u.z() * u.z(), u.x() * u.y(),
      u.x() * u.z(), u.y() * u.z();
  return h;
}

}  // namespace standcal
