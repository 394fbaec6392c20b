#include "calib/full_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "calib/distributions.hpp"
#include "calib/identifiability.hpp"
#include "calib/parameters.hpp"
#include "calib/units.hpp"

namespace standcal {
namespace {

// Stand errors in the order they are kept when the programme cannot separate them:
// the alpha1 zero offset stands for the whole rotation about the outer axis (model.md),
// the alpha2 zero offset is the first to give way to the mounting about the inner axis.
enum StandSlot : int {
  kLevellingX = 0,
  kAlpha1Offset,
  kSkewY,
  kAlpha1Scale,
  kAlpha2Scale,
  kLevellingZ,
  kSkewZ,
  kAlpha2Offset
};

FullModelParameter make_parameter(FullModelParameter::Kind kind, std::string name,
                                  std::string description, std::string unit, double scale) {
  FullModelParameter p;
  p.kind = kind;
  p.name = std::move(name);
  p.description = std::move(description);
  p.unit = std::move(unit);
  p.report_scale = scale;
  return p;
}

void add_unit_parameters(FullModelLayout& layout) {
  static const std::array<const char*, kUnitParameterCount> descriptions{
      "the bias of x",
      "the bias of y",
      "the bias of z",
      "the scale-factor error of x",
      "the scale-factor error of y",
      "the scale-factor error of z",
      "the non-orthogonality x–y",
      "the non-orthogonality x–z",
      "the non-orthogonality y–z"};
  for (int i = 0; i < kUnitParameterCount; ++i) {
    layout.parameters.push_back(
        make_parameter(FullModelParameter::Kind::unit, std::string(kUnitParameterNames[i]),
                       descriptions[i], std::string(kUnitParameterUnits[i]), report_scale(i)));
  }
}

void add_mounting_parameters(FullModelLayout& layout) {
  static const std::array<const char*, 3> axes{"x", "y", "z"};
  if (layout.mounting_model == MountingModel::common_fixture) {
    for (int a = 0; a < 3; ++a)
      layout.parameters.push_back(make_parameter(
          FullModelParameter::Kind::mounting, std::string("mounting_psi_") + axes[a],
          std::string("the mounting misalignment about ") + axes[a], "arcsec", kRadToArcsec));
    return;
  }
  const bool several = layout.mounts.size() > 1;
  for (Mount m : layout.mounts) {
    for (int a = 0; a < 3; ++a) {
      std::string description = std::string("the mounting misalignment about ") + axes[a];
      if (several) description += " (mount " + mount_name(m) + ")";
      layout.parameters.push_back(make_parameter(FullModelParameter::Kind::mounting,
                                                 "mount_" + mount_name(m) + "_psi_" + axes[a],
                                                 description, "arcsec", kRadToArcsec));
    }
  }
}

void add_stand_parameters(FullModelLayout& layout) {
  using K = FullModelParameter::Kind;
  auto& ps = layout.parameters;
  ps.push_back(make_parameter(K::stand, "levelling_x", "the levelling error about x_S", "arcsec",
                              kRadToArcsec));
  ps.push_back(make_parameter(K::stand, "alpha1_offset",
                              "the zero offset of the outer-axis angle sensor", "arcsec",
                              kRadToArcsec));
  ps.push_back(make_parameter(K::stand, "skew_y", "the skew of the inner axis about y", "arcsec",
                              kRadToArcsec));
  ps.push_back(make_parameter(K::stand, "alpha1_scale",
                              "the scale error of the outer-axis angle sensor", "ppm", 1.0 / kPpm));
  ps.push_back(make_parameter(K::stand, "alpha2_scale",
                              "the scale error of the inner-axis angle sensor", "ppm", 1.0 / kPpm));
  ps.push_back(make_parameter(K::stand, "levelling_z",
                              "the levelling error about z_S (the outer axis)", "arcsec",
                              kRadToArcsec));
  ps.push_back(make_parameter(K::stand, "skew_z", "the skew of the inner axis about the outer axis",
                              "arcsec", kRadToArcsec));
  ps.push_back(make_parameter(K::stand, "alpha2_offset",
                              "the zero offset of the inner-axis angle sensor", "arcsec",
                              kRadToArcsec));
}

void add_antisymmetric_parameters(FullModelLayout& layout) {
  using K = FullModelParameter::Kind;
  // Gamma_antisymmetric = -[theta x]: the same first-order effect as a rotation theta.
  layout.parameters.push_back(make_parameter(K::gamma_antisymmetric, "gamma_antisymmetric_yz",
                                             "the antisymmetric part of the non-orthogonality y–z",
                                             "arcsec", kRadToArcsec));
  layout.parameters.push_back(make_parameter(K::gamma_antisymmetric, "gamma_antisymmetric_xz",
                                             "the antisymmetric part of the non-orthogonality x–z",
                                             "arcsec", kRadToArcsec));
  layout.parameters.push_back(make_parameter(K::gamma_antisymmetric, "gamma_antisymmetric_xy",
                                             "the antisymmetric part of the non-orthogonality x–y",
                                             "arcsec", kRadToArcsec));
}

int mount_slot(const FullModelLayout& layout, Mount m) {
  for (std::size_t i = 0; i < layout.mounts.size(); ++i)
    if (layout.mounts[i] == m) return static_cast<int>(i);
  throw std::invalid_argument("mount " + mount_name(m) + " is not part of this programme's model");
}

StandErrors stand_errors_from(const FullModelLayout& layout, const Eigen::VectorXd& p) {
  StandErrors s;
  const int o = layout.stand_offset;
  s.levelling_x_rad = p[o + kLevellingX];
  s.levelling_z_rad = p[o + kLevellingZ];
  s.alpha1_offset_rad = p[o + kAlpha1Offset];
  s.alpha2_offset_rad = p[o + kAlpha2Offset];
  s.alpha1_scale = p[o + kAlpha1Scale];
  s.alpha2_scale = p[o + kAlpha2Scale];
  s.skew_y_rad = p[o + kSkewY];
  s.skew_z_rad = p[o + kSkewZ];
  for (std::size_t i = 0; i < layout.mounts.size(); ++i) {
    const int slot =
        layout.mounting_model == MountingModel::common_fixture ? 0 : static_cast<int>(i);
    s.mounting_rad[static_cast<int>(layout.mounts[i])] =
        p.segment<3>(layout.mounting_offset + 3 * slot);
  }
  return s;
}

UnitErrors unit_errors_from(const FullModelLayout& layout, const Eigen::VectorXd& p) {
  UnitErrors u;
  u.bias_g = p.segment<3>(kBiasX);
  u.scale = p.segment<3>(kScaleX);
  u.set_gamma_pair_sums_rad(p.segment<3>(kGamma12));
  u.gamma_rad -= cross_matrix(p.segment<3>(layout.antisymmetric_offset));
  return u;
}

std::string format_coefficient_term(double c, const std::string& name) {
  if (std::abs(c - 1) < 1e-3) return " + " + name;
  if (std::abs(c + 1) < 1e-3) return " - " + name;
  std::ostringstream os;
  os.precision(3);
  os << (c < 0 ? " - " : " + ") << std::abs(c) << "*" << name;
  return os.str();
}

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i) {
    if (i > 0) out += (i + 1 == words.size()) ? " and " : ", ";
    out += words[i];
  }
  return out;
}

}  // namespace

FullModelLayout full_model_layout(const std::vector<StandPose>& poses, MountingModel mounting) {
  FullModelLayout layout;
  layout.mounting_model = mounting;
  for (const auto& pose : poses)
    if (std::find(layout.mounts.begin(), layout.mounts.end(), pose.mount) == layout.mounts.end())
      layout.mounts.push_back(pose.mount);
  if (layout.mounts.empty()) layout.mounts.push_back(Mount::x);
  add_unit_parameters(layout);
  layout.mounting_offset = layout.size();
  add_mounting_parameters(layout);
  layout.stand_offset = layout.size();
  add_stand_parameters(layout);
  layout.antisymmetric_offset = layout.size();
  add_antisymmetric_parameters(layout);
  return layout;
}

Vec3 full_model_output(const FullModelLayout& layout, const Eigen::VectorXd& p,
                       const StandPose& pose) {
  (void)mount_slot(layout, pose.mount);  // rejects a mount the layout has no parameters for
  const Vec3 u_true = true_up_vector(pose.alpha1_deg * kDegToRad, pose.alpha2_deg * kDegToRad,
                                     pose.mount, stand_errors_from(layout, p));
  return unit_output_g(unit_errors_from(layout, p), u_true);
}

Eigen::MatrixXd full_model_jacobian(const FullModelLayout& layout, const Eigen::VectorXd& p,
                                    const StandPose& pose) {
  constexpr double kStep = 1e-6;  // parameters are small angles / ratios; truncation error ~1e-12
  Eigen::MatrixXd jac(3, layout.size());
  Eigen::VectorXd q = p;
  for (int j = 0; j < layout.size(); ++j) {
    q[j] = p[j] + kStep;
    const Vec3 plus = full_model_output(layout, q, pose);
    q[j] = p[j] - kStep;
    const Vec3 minus = full_model_output(layout, q, pose);
    q[j] = p[j];
    jac.col(j) = (plus - minus) / (2 * kStep);
  }
  return jac;
}

bool Observability::is_kept(int layout_index) const {
  return std::find(kept.begin(), kept.end(), layout_index) != kept.end();
}

Observability analyse_observability(const FullModelLayout& layout,
                                    const std::vector<StandPose>& poses,
                                    const std::vector<double>& weights, double tolerance) {
  const int n = layout.size();
  const int rows = 3 * static_cast<int>(poses.size());
  Eigen::MatrixXd a(rows, n);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(n);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double w = weights.empty() ? 1.0 : weights[k];
    a.middleRows(3 * static_cast<int>(k), 3) = w * full_model_jacobian(layout, nominal, poses[k]);
  }
  Eigen::VectorXd norms = a.colwise().norm().transpose();
  // A column this small is numerical noise of the differences: the parameter has no effect.
  const double negligible = 1e-9 * norms.maxCoeff();
  for (int j = 0; j < n; ++j)
    if (norms[j] < negligible) norms[j] = 0;
  Eigen::MatrixXd scaled = a;
  for (int j = 0; j < n; ++j)
    if (norms[j] > 0)
      scaled.col(j) /= norms[j];
    else
      scaled.col(j).setZero();

  Observability obs;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled);
  obs.singular_values = svd.singularValues();
  const double s_max = obs.singular_values.size() > 0 ? obs.singular_values[0] : 0;
  for (int i = 0; i < obs.singular_values.size(); ++i)
    if (obs.singular_values[i] > tolerance * s_max) ++obs.svd_rank;

  // Keep parameters in layout (priority) order while they add a direction the kept ones
  // do not already span; the rest are fixed to zero and folded into their partners.
  Eigen::MatrixXd basis(rows, 0);
  for (int j = 0; j < n; ++j) {
    bool add = false;
    Eigen::VectorXd residual;
    if (norms[j] > 0) {
      residual = scaled.col(j) - basis * (basis.transpose() * scaled.col(j));
      residual -=
          basis * (basis.transpose() * residual);  // second pass for numerical orthogonality
      add = residual.norm() > std::sqrt(tolerance);
    }
    if (add) {
      obs.kept.push_back(j);
      basis.conservativeResize(Eigen::NoChange, basis.cols() + 1);
      basis.col(basis.cols() - 1) = residual / residual.norm();
    } else {
      obs.fixed.push_back(j);
    }
  }

  Eigen::MatrixXd kept_cols(rows, static_cast<int>(obs.kept.size()));
  for (std::size_t i = 0; i < obs.kept.size(); ++i)
    kept_cols.col(static_cast<int>(i)) = a.col(obs.kept[i]);
  obs.absorbed =
      Eigen::MatrixXd::Zero(static_cast<int>(obs.fixed.size()), static_cast<int>(obs.kept.size()));
  const auto qr = kept_cols.colPivHouseholderQr();
  for (std::size_t f = 0; f < obs.fixed.size(); ++f) {
    const int j = obs.fixed[f];
    const FullModelParameter& par = layout.parameters[j];
    if (norms[j] == 0) {
      obs.notes.push_back(par.description +
                          " has no effect on any measurement of this programme: fixed to zero.");
      continue;
    }
    const Eigen::VectorXd coeff = qr.solve(Eigen::VectorXd(a.col(j)));
    std::vector<std::string> partners;
    for (std::size_t i = 0; i < obs.kept.size(); ++i) {
      // Significance judged on the scaled columns: how much of the direction is this partner's.
      const double share = std::abs(coeff[static_cast<int>(i)]) * norms[obs.kept[i]] / norms[j];
      if (share < 1e-3) continue;
      obs.absorbed(static_cast<int>(f), static_cast<int>(i)) = coeff[static_cast<int>(i)];
      partners.push_back(layout.parameters[obs.kept[i]].description);
    }
    obs.notes.push_back(par.description + " (" + par.name + ") is indistinguishable from " +
                        join_words(partners) +
                        " with this programme: fixed to zero, its effect is carried by " +
                        (partners.size() == 1 ? "that estimate." : "those estimates."));
  }

  for (std::size_t i = 0; i < obs.kept.size(); ++i) {
    std::string name = layout.parameters[obs.kept[i]].name;
    for (std::size_t f = 0; f < obs.fixed.size(); ++f) {
      const double c = obs.absorbed(static_cast<int>(f), static_cast<int>(i));
      if (c != 0) name += format_coefficient_term(c, layout.parameters[obs.fixed[f]].name);
    }
    obs.kept_combination_names.push_back(name);
  }
  return obs;
}

namespace {

struct WeightedProblem {
  const FullModelLayout& layout;
  const Observability& obs;
  std::vector<StandPose> poses;
  std::vector<Vec3> measured_g;
  std::vector<Vec3> sigma_g;
  std::vector<NoiseRow> noise_rows;  // the residual vector's rows, for the wander
  GaussMarkovNoise noise;            // white: weighted least squares; else GLS

  Eigen::VectorXd full_vector(const Eigen::VectorXd& q) const {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(layout.size());
    for (std::size_t i = 0; i < obs.kept.size(); ++i) p[obs.kept[i]] = q[static_cast<int>(i)];
    return p;
  }
  // Normalised residuals (measured - model) / sigma.
  Eigen::VectorXd residuals(const Eigen::VectorXd& q) const {
    const Eigen::VectorXd p = full_vector(q);
    Eigen::VectorXd r(3 * static_cast<int>(poses.size()));
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const Vec3 model = full_model_output(layout, p, poses[k]);
      r.segment<3>(3 * static_cast<int>(k)) = (measured_g[k] - model).cwiseQuotient(sigma_g[k]);
    }
    return decorrelate(noise_rows, noise, r);
  }
  // d model / d q, normalised by sigma (the Jacobian of -residuals).
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& q) const {
    const Eigen::VectorXd p = full_vector(q);
    Eigen::MatrixXd jac(3 * static_cast<int>(poses.size()), static_cast<int>(obs.kept.size()));
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const Eigen::MatrixXd full = full_model_jacobian(layout, p, poses[k]);
      for (std::size_t i = 0; i < obs.kept.size(); ++i)
        jac.block<3, 1>(3 * static_cast<int>(k), static_cast<int>(i)) =
            full.col(obs.kept[i]).cwiseQuotient(sigma_g[k]);
    }
    return decorrelate(noise_rows, noise, jac);
  }
};

// Inverse of J^T J with column equilibration, so mixed units (g, rad, ppm) do not hurt.
Eigen::MatrixXd covariance_from_jacobian(const Eigen::MatrixXd& jac) {
  const Eigen::VectorXd d = jac.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd scaled = jac * d.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd info = scaled.transpose() * scaled;
  const Eigen::MatrixXd inv =
      info.ldlt().solve(Eigen::MatrixXd::Identity(info.rows(), info.cols()));
  return d.cwiseInverse().asDiagonal() * inv * d.cwiseInverse().asDiagonal();
}

// How much each kept parameter's sigma widens for an estimated noise model (noise_model.hpp).
SigmaWidening sigma_widening(const WeightedProblem& problem, const Eigen::VectorXd& q,
                             const FitNoiseChoice& noise) {
  WeightedProblem white = problem;
  white.noise = {};
  const Eigen::MatrixXd jac_white = white.jacobian(q);
  return widen_for_estimated_noise(
      [&](const GaussMarkovNoise& n) {
        return Eigen::VectorXd(
            covariance_from_jacobian(decorrelate(problem.noise_rows, n, jac_white)).diagonal());
      },
      noise);
}

// Levenberg–Marquardt on the kept parameters, starting from zero (every error is small).
Eigen::VectorXd solve_levenberg_marquardt(const WeightedProblem& problem, int max_iterations) {
  const int k = static_cast<int>(problem.obs.kept.size());
  Eigen::VectorXd q = Eigen::VectorXd::Zero(k);
  Eigen::VectorXd r = problem.residuals(q);
  double cost = r.squaredNorm();
  double lambda = 1e-6;
  for (int it = 0; it < max_iterations; ++it) {
    const Eigen::MatrixXd jac = problem.jacobian(q);
    const Eigen::MatrixXd a = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    bool improved = false;
    Eigen::VectorXd step;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      Eigen::MatrixXd damped = a;
      damped.diagonal() += lambda * a.diagonal().cwiseMax(1e-300);
      const Eigen::VectorXd d = damped.diagonal().cwiseSqrt().cwiseInverse();
      const Eigen::MatrixXd scaled = d.asDiagonal() * damped * d.asDiagonal();
      step = d.asDiagonal() * scaled.ldlt().solve(d.asDiagonal() * g);
      const Eigen::VectorXd r_new = problem.residuals(q + step);
      const double cost_new = r_new.squaredNorm();
      if (cost_new <= cost) {
        q += step;
        r = r_new;
        const double decrease = cost - cost_new;
        cost = cost_new;
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
        if (decrease <= 1e-12 * (1 + cost)) return q;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return q;
}

}  // namespace

std::string unit_unobservable_reason(const FullModelLayout& layout, const Observability& obs,
                                     int unit_parameter) {
  const auto it = std::find(obs.kept.begin(), obs.kept.end(), unit_parameter);
  const std::string& what = layout.parameters[unit_parameter].description;
  if (it == obs.kept.end())
    return "this programme cannot separate " + what + " from the other errors (see notes)";
  // Kept, but standing for a combination with a stand or mounting error: not a unit property.
  const int i = static_cast<int>(it - obs.kept.begin());
  for (std::size_t f = 0; f < obs.fixed.size(); ++f) {
    if (obs.absorbed(static_cast<int>(f), i) == 0) continue;
    if (layout.parameters[obs.fixed[f]].kind == FullModelParameter::Kind::gamma_antisymmetric)
      continue;
    std::string reason = "this programme cannot separate " + what + " from " +
                         layout.parameters[obs.fixed[f]].description + " (it would estimate " +
                         obs.kept_combination_names[static_cast<std::size_t>(i)] + ")";
    if (layout.mounting_model == MountingModel::per_mount)
      reason += "; with a rigid fixture (common mounting) it is observable";
    return reason;
  }
  return {};
}

namespace {

// A fit that would report nothing of the unit is no fit: refused with the counts.
void require_some_unit_parameter(const FullModelLayout& layout, const Observability& obs,
                                 const std::vector<PositionAverage>& positions) {
  for (int i = 0; i < kUnitParameterCount; ++i)
    if (unit_unobservable_reason(layout, obs, i).empty()) return;
  throw CannotFit("cannot fit (full vector): " +
                  positions_for_unknowns(positions, static_cast<int>(layout.size())) +
                  "; this programme cannot separate any of the unit's parameters from the stand's");
}

}  // namespace

namespace {

// What a full-vector fit is built on: the poses, the means and their standard errors, the
// parameters the model has for this programme and those it can observe.
struct FullFitInput {
  std::vector<StandPose> poses;
  std::vector<Vec3> measured, sigmas;
  FullModelLayout layout;
  Observability obs;
};

FullFitInput full_fit_input(const std::vector<PositionAverage>& positions,
                            const FullFitOptions& options) {
  require_positions(positions, "cannot fit (full vector)");
  FullFitInput in;
  std::vector<double> weights;
  for (const auto& pa : positions) {
    in.poses.push_back({pa.alpha1_cmd_deg, pa.alpha2_cmd_deg, pa.mount});
    in.measured.push_back(pa.mean_g);
    const Vec3 s = pa.standard_error_g.cwiseMax(options.sigma_floor_g);
    in.sigmas.push_back(s);
    weights.push_back(1.0 / s.mean());
  }
  in.layout = full_model_layout(in.poses, options.mounting);
  in.obs = analyse_observability(in.layout, in.poses, weights, options.observability_tolerance);
  require_some_unit_parameter(in.layout, in.obs, positions);
  return in;
}

// The white fit (each mean independent), and the noise model chosen from its residuals.
FitNoiseChoice white_fit_and_noise(WeightedProblem& problem, Eigen::VectorXd& q,
                                   const std::vector<PositionAverage>& positions,
                                   const FullFitOptions& options) {
  q = solve_levenberg_marquardt(problem, options.max_iterations);
  return choose_fit_noise(problem.noise_rows, problem.jacobian(q), problem.residuals(q),
                          options.noise, positions);
}

}  // namespace

constexpr double kModelMisfitP = 1e-3;  // P of the noise model's own bar for a finding

// What WanderAgainstWhite says of the white fit at q.
WanderAgainstWhite wander_against_white(const WeightedProblem& problem, const Eigen::VectorXd& q) {
  const Eigen::MatrixXd X = problem.jacobian(q);
  const Eigen::VectorXd y = problem.residuals(q);
  const double white = restricted_log_likelihood(problem.noise_rows, X, y, GaussMarkovNoise{});
  return [rows = problem.noise_rows, X, y, white](const GaussMarkovNoise& n) {
    return 2 * (white - restricted_log_likelihood(rows, X, y, n));
  };
}

std::optional<FitNoiseChoice> full_vector_noise_choice(
    const std::vector<PositionAverage>& positions, const FitNoiseOptions& noise,
    WanderAgainstWhite* against_white) {
  FullFitOptions options;
  options.noise = noise;
  try {
    const FullFitInput in = full_fit_input(positions, options);
    WeightedProblem problem{in.layout, in.obs, in.poses, in.measured, in.sigmas, {}, {}};
    problem.noise_rows = full_vector_noise_rows(positions, options.sigma_floor_g);
    Eigen::VectorXd q;
    const FitNoiseChoice choice = white_fit_and_noise(problem, q, positions, options);
    const int dof =
        static_cast<int>(3 * positions.size() - in.obs.kept.size()) - choice.weighted_parameters;
    // The model check: a full-vector model that does not fit these means (a stand error it
    // leaves out, a re-mount it takes as rigid) would pass its misfit off as wander, so its
    // estimate is not offered, nor its rows' judgement of another wander. It is made against
    // the noise the full vector weights with, a wander below the bar of a finding too: against
    // white noise alone such a wander is itself a misfit, and under a 3x wander of 600 s, tau
    // given, 2 of 200 diagnostic32 runs were set aside so and their joint fits weighted as
    // white noise, the biases 7 and 17 sigma off.
    const auto fits = [&](const WeightedProblem& p, const Eigen::VectorXd& at) {
      return dof <= 0 || chi_square_upper_tail(p.residuals(at).squaredNorm(), dof) >= kModelMisfitP;
    };
    // The judge is of the white fit, which the search under the chosen noise moves from.
    WanderAgainstWhite judge = against_white ? wander_against_white(problem, q) : nullptr;
    if (choice.noise.white()) {
      if (against_white && fits(problem, q)) *against_white = std::move(judge);
      return choice;
    }
    problem.noise = choice.noise;
    q = solve_levenberg_marquardt(problem, options.max_iterations);
    if (!fits(problem, q)) return std::nullopt;
    if (against_white) *against_white = std::move(judge);
    return choice;
  } catch (const CannotFit&) {
    return std::nullopt;
  }
}

FitResult fit_full_vector(const std::vector<PositionAverage>& positions,
                          const FullFitOptions& options) {
  const FullFitInput in = full_fit_input(positions, options);
  const FullModelLayout& layout = in.layout;
  const Observability& obs = in.obs;
  const std::vector<StandPose>& poses = in.poses;
  const std::vector<Vec3>& measured = in.measured;
  const std::vector<Vec3>& sigmas = in.sigmas;
  WeightedProblem problem{layout, obs, poses, measured, sigmas, {}, {}};
  problem.noise_rows = full_vector_noise_rows(positions, options.sigma_floor_g);

  Eigen::VectorXd q;
  // The noise model from the white fit's residuals, then the fit again under it.
  const FitNoiseChoice noise = white_fit_and_noise(problem, q, positions, options);
  if (!noise.noise.white()) {
    problem.noise = noise.noise;
    q = solve_levenberg_marquardt(problem, options.max_iterations);
  }
  const Eigen::MatrixXd cov = covariance_from_jacobian(problem.jacobian(q));
  const SigmaWidening widen = sigma_widening(problem, q, noise);
  WeightedProblem check = problem;  // the model check: against the wander only when it is a finding
  check.noise = noise.check_noise;
  const Eigen::VectorXd r = check.residuals(q);
  const Eigen::VectorXd p = problem.full_vector(q);

  FitResult fit;
  fit.estimator = "full";
  fit.noise = noise.finding;
  fit.positions = static_cast<int>(positions.size());
  fit.parameters_estimated = static_cast<int>(obs.kept.size());
  fit.redundancy = 3 * fit.positions - fit.parameters_estimated - noise.parameters;
  fit.chi2 = r.squaredNorm();
  fit.chi2_dof =
      fit.redundancy > 0 ? fit.chi2 / fit.redundancy : std::numeric_limits<double>::quiet_NaN();

  double sum_sq = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    PositionResidual res;
    res.pos = positions[k].pos;
    res.alpha1_cmd_deg = poses[k].alpha1_deg;
    res.alpha2_cmd_deg = poses[k].alpha2_deg;
    res.mount = poses[k].mount;
    res.residual_g = measured[k] - full_model_output(layout, p, poses[k]);
    res.sigma_g = sigmas[k];
    sum_sq += res.residual_g.squaredNorm();
    fit.residuals.push_back(res);
  }
  fit.residual_rms_g = std::sqrt(sum_sq / (3.0 * static_cast<double>(poses.size())));

  // Map from layout index to position in q (or -1 when fixed).
  std::vector<int> slot(layout.size(), -1);
  for (std::size_t i = 0; i < obs.kept.size(); ++i) slot[obs.kept[i]] = static_cast<int>(i);

  fit.correlation = Eigen::MatrixXd::Constant(kUnitParameterCount, kUnitParameterCount,
                                              std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < kUnitParameterCount; ++i) {
    const std::string reason = unit_unobservable_reason(layout, obs, i);
    if (!reason.empty()) {
      fit.unit[i].unobservable_reason = reason;
      continue;
    }
    fit.unit[i].value = q[slot[i]];
    fit.unit[i].sigma = std::sqrt(cov(slot[i], slot[i])) * widen.factor[slot[i]];
    fit.unit[i].dof = widen.dof[slot[i]];
    for (int j = 0; j < kUnitParameterCount; ++j)
      if (slot[j] >= 0)
        fit.correlation(i, j) =
            cov(slot[i], slot[j]) / std::sqrt(cov(slot[i], slot[i]) * cov(slot[j], slot[j]));
  }

  for (std::size_t i = 0; i < obs.kept.size(); ++i) {
    const FullModelParameter& par = layout.parameters[obs.kept[i]];
    if (par.kind == FullModelParameter::Kind::unit) continue;
    StandEstimate e;
    e.name = obs.kept_combination_names[i];
    e.description = par.description;
    if (e.name != par.name)
      e.description += " (with what it cannot be told apart from: " + e.name + ")";
    e.value = q[static_cast<int>(i)] * par.report_scale;
    e.sigma = std::sqrt(cov(static_cast<int>(i), static_cast<int>(i))) *
              widen.factor[static_cast<int>(i)] * par.report_scale;
    e.unit = par.unit;
    fit.stand.push_back(e);
  }

  fit.notes = obs.notes;
  fit.notes.push_back(
      "gamma12, gamma13, gamma23 are the pair sums gamma_ij + gamma_ji; the antisymmetric part "
      "cannot be told from the mounting (model.md).");
  if (layout.mounting_model == MountingModel::common_fixture && layout.mounts.size() > 1)
    fit.notes.push_back(
        "one rigid fixture assumed across the mounts (--mounting common): an error in "
        "re-seating it for a mount goes into the gamma pair sums one for one (each takes the "
        "difference of two mounts' re-seatings), and neither their sigmas nor the model check "
        "can see it; budget it "
        "(stand.remount_arcsec of the budget file) or fit --mounting per-mount, which reports "
        "the gamma pair sums unobservable.");
  if (fit.redundancy <= 0)
    fit.notes.push_back("zero redundancy: the fit is exact and cannot check the model.");
  return fit;
}

FitResult fit_full_vector(const std::vector<PositionAverage>& positions,
                          const FitNoiseOptions& noise) {
  FullFitOptions options;
  options.noise = noise;
  return fit_full_vector(positions, options);
}

}  // namespace standcal
