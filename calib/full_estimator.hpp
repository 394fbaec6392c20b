#pragma once
// The full-vector estimator (issue 3): all three components of J at every position, the
// exact rotation model of docs/model.md, the nine unit parameters together with stand
// and mounting errors, by Levenberg–Marquardt. What a programme cannot separate is found
// by an SVD of the column-scaled Jacobian, named, and constrained instead of guessed.
#include <Eigen/Dense>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/model.hpp"
#include "calib/noise_model.hpp"
#include "calib/position_average.hpp"

namespace standcal {

// Where the stand was for one measurement; what the design and the estimator share.
struct StandPose {
  double alpha1_deg = 0;
  double alpha2_deg = 0;
  Mount mount = Mount::x;
};

// One parameter of the full-vector model, in the order the estimator prefers to keep
// them when the programme cannot separate them (unit first, antisymmetric gamma last).
struct FullModelParameter {
  enum class Kind { unit, mounting, stand, gamma_antisymmetric };
  Kind kind = Kind::unit;
  std::string name;         // e.g. "bias_x", "mounting_y_about_z", "levelling_x"
  std::string description;  // plain words, for notes
  std::string unit;         // report unit
  double report_scale = 1;  // internal value * report_scale = report value
};

// How the unit's mounting misalignment is modelled when a programme re-mounts it.
enum class MountingModel {
  // One misalignment of the unit in a rigid fixture whose faces are exact, shared by
  // every mount: the premise under which the classic programme measures gamma (model.md).
  common_fixture,
  // An independent misalignment per mount: re-mount errors unknown. Then the classic
  // programme cannot separate gamma from the relative re-mount errors (reported as such).
  per_mount,
};

// The parameter vector of the full model for the mountings a programme uses.
struct FullModelLayout {
  MountingModel mounting_model = MountingModel::common_fixture;
  std::vector<Mount> mounts;  // in order of first use
  std::vector<FullModelParameter>
      parameters;  // unit (9), mounting (3 per mount), stand, antisymmetric gamma (3)
  int mounting_offset = 9;
  int stand_offset = 0;
  int antisymmetric_offset = 0;

  int size() const { return static_cast<int>(parameters.size()); }
};

FullModelLayout full_model_layout(const std::vector<StandPose>& poses,
                                  MountingModel mounting = MountingModel::common_fixture);

// Predicted J (in g) at a commanded pose for a parameter vector of the layout (exact rotations).
Vec3 full_model_output(const FullModelLayout& layout, const Eigen::VectorXd& p,
                       const StandPose& pose);

// d J / d p at p for one pose: 3 x layout.size(), central differences.
Eigen::MatrixXd full_model_jacobian(const FullModelLayout& layout, const Eigen::VectorXd& p,
                                    const StandPose& pose);

// Which parameters a programme can identify, and what the others are folded into.
struct Observability {
  std::vector<int> kept;   // layout indices estimated, in layout order
  std::vector<int> fixed;  // layout indices fixed to zero
  // absorbed(fixed_i, kept_j): the estimate of kept_j stands for p_kept + coeff * p_fixed.
  Eigen::MatrixXd absorbed;
  int svd_rank = 0;
  Eigen::VectorXd singular_values;  // of the column-scaled Jacobian, descending
  std::vector<std::string> notes;   // one plain sentence per fixed parameter
  // The identifiable combination a kept parameter estimates, e.g. "alpha1_offset + levelling_z".
  std::vector<std::string> kept_combination_names;

  bool is_kept(int layout_index) const;
};

// Rank analysis of the weighted Jacobian at the nominal point (all errors zero):
// structural observability of the programme. `weights` per pose (1 / sigma of J, any
// positive numbers; empty = equal). tolerance: relative singular value / residual norm
// below which a direction counts as unobservable.
Observability analyse_observability(const FullModelLayout& layout,
                                    const std::vector<StandPose>& poses,
                                    const std::vector<double>& weights = {},
                                    double tolerance = 1e-6);

// Why a unit parameter (0..8) cannot be reported for this programme, or empty when it can:
// not kept, or kept only as a combination with a stand or mounting error.
std::string unit_unobservable_reason(const FullModelLayout& layout, const Observability& obs,
                                     int unit_parameter);

struct FullFitOptions {
  int max_iterations = 50;
  double observability_tolerance = 1e-6;
  double sigma_floor_g = 1e-9;  // standard errors below this (noise-free data) are raised to it
  MountingModel mounting = MountingModel::common_fixture;
  // Dwell means close in time share bias wander: weighted by the covariance it implies
  // (generalised least squares) when the run shows it or it is specified.
  FitNoiseOptions noise;
};

// The full-vector estimate from per-position averages (model.md, "Full measurement model").
FitResult fit_full_vector(const std::vector<PositionAverage>& positions,
                          const FullFitOptions& options = {});
// The same with every option at its default but the noise weighting.
FitResult fit_full_vector(const std::vector<PositionAverage>& positions,
                          const FitNoiseOptions& noise);

// How the full vector of these dwell means receives a wander proposed from elsewhere (the
// invariant rows' own estimate): 2 (restricted log L(white) - log L(noise)) on its white
// fit's residuals, above 0 where its rows favour white noise over that wander.
using WanderAgainstWhite = std::function<double(const GaussMarkovNoise&)>;

// The noise model the full-vector fit of these dwell means weights with, chosen from its
// white fit's residuals (three rows per position): for an estimator that sees one row per
// position of the same dwells (the invariant fit) and pins the wander poorly from those.
// Nullopt when the full-vector model cannot be fitted to this programme, or does not fit
// these means under the noise it chose (chi-square at P < 1e-3): its misfit is not noise.
// With a choice from a model that fits, `against_white` (when given) receives how those rows
// receive another wander; it stays empty where the white model does not fit the means.
std::optional<FitNoiseChoice> full_vector_noise_choice(
    const std::vector<PositionAverage>& positions, const FitNoiseOptions& noise,
    WanderAgainstWhite* against_white = nullptr);

}  // namespace standcal
