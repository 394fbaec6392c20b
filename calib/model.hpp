#pragma once
// The measurement model of docs/model.md (binding conventions): up-vector, exact
// rotations, the unit's nine parameters, stand and mounting errors, and the invariant
// measurement delta_J_L.
#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <string>

namespace standcal {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// Mounting of the unit on the inner table (model.md, classic program).
enum class Mount : std::uint8_t { x = 0, y = 1, z = 2 };
inline constexpr int kMountCount = 3;
std::string mount_name(Mount m);
// Parses "x", "y" or "z"; returns false on anything else.
bool parse_mount(const std::string& text, Mount& out);

// C1(a): frame rotation by +a about z_S (outer axis).
Mat3 C1(double a_rad);
// C2(a): frame rotation by -a about x (inner axis).
Mat3 C2(double a_rad);
// Exact small-rotation matrix exp(-[theta x]) (Rodrigues), for any angle size.
Mat3 rotation_exp(const Vec3& theta_rad);
// Skew-symmetric cross-product matrix [v x].
Mat3 cross_matrix(const Vec3& v);

// u(a1, a2) = C2(a2) C1(a1) [0,1,0]^T = [sin a1, cos a1 cos a2, cos a1 sin a2].
Vec3 up_vector_table(double alpha1_rad, double alpha2_rad);
// Map from table axes to instrument axes for a mounting (model.md): x: identity,
// y: [uT3, uT1, uT2], z: [uT2, uT3, uT1].
Mat3 mount_permutation(Mount m);
// The commanded up-vector in instrument axes for a mounting.
Vec3 up_vector(double alpha1_rad, double alpha2_rad, Mount m = Mount::x);

// The nine instrument errors. Gamma is kept as the six individual tilts gamma_ij
// (input axis i towards axis j); gravity only reveals the pair sums (model.md).
struct UnitErrors {
  Vec3 bias_g = Vec3::Zero();     // Delta, in g
  Vec3 scale = Vec3::Zero();      // delta k, dimensionless
  Mat3 gamma_rad = Mat3::Zero();  // zero diagonal, off-diagonal gamma_ij

  // The pair sums gamma12, gamma13, gamma23 (rad).
  Vec3 gamma_pair_sums_rad() const;
  // Sets a symmetric Gamma from pair sums (each tilt half the sum).
  void set_gamma_pair_sums_rad(const Vec3& sums);
  // (I + dK)(I + Gamma): the matrix that maps true specific force to output.
  Mat3 output_matrix() const;
  // From the paper's nine in calib/parameters.hpp's order (bias in g, scale, the gamma pair
  // sums in rad; Gamma made symmetric).
  static UnitErrors from_parameters(const Eigen::Matrix<double, 9, 1>& p);
};

// Stand and mounting errors of model.md, all small angles in rad.
struct StandErrors {
  double levelling_x_rad = 0;    // levelling about x_S
  double levelling_z_rad = 0;    // levelling about z_S
  double alpha1_offset_rad = 0;  // angle-sensor zero error of the outer axis
  double alpha2_offset_rad = 0;  // angle-sensor zero error of the inner axis
  double alpha1_scale = 0;       // angle-sensor scale error of the outer axis
  double alpha2_scale = 0;       // angle-sensor scale error of the inner axis
  double skew_y_rad = 0;         // non-perpendicularity of inner vs outer axis, about y
  double skew_z_rad = 0;         // ... about z (the outer axis)
  std::array<Vec3, kMountCount> mounting_rad{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
};

// The true gravity "up" direction in instrument axes at commanded angles, with every
// stand and mounting error applied through exact rotations (model.md):
// u_true = Cpsi P_mount C2(a2 + da2) Cn C1(a1 + da1) Ceps [0,1,0]^T.
Vec3 true_up_vector(double alpha1_rad, double alpha2_rad, Mount m, const StandErrors& stand);

// J = Delta + (I + dK)(I + Gamma) u_true, noise-free, in g.
Vec3 unit_output_g(const UnitErrors& unit, const Vec3& u_true);

// delta_J_L = u^T J - 1 (model.md, the paper's invariant measurement).
double delta_J_L(const Vec3& u, const Vec3& J);

// Regressor row of the linear invariant model (model.md eq. 22):
// [ux, uy, uz, ux^2, uy^2, uz^2, ux uy, ux uz, uy uz].
Eigen::Matrix<double, 1, 9> invariant_regressor(const Vec3& u);

}  // namespace standcal
