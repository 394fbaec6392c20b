#pragma once
// Experiment design (issue 3): what a programme can measure and how long it takes.
// Information matrices for the invariant model (model.md eq. 22) and the full-vector
// model, predicted 1 sigma per parameter, D- and A-criteria, bench time, D-optimal
// programmes over the stand's reachable angles, and dwell allocation for a target.
//
// Noise convention (model.md): a dwell of T s has a mean with sigma N / sqrt(T) per axis;
// the invariant measurement's sigma is that projected on u, which for equal axes is the same.
// With bias wander (issue 21) the means of dwells close in time share it: the information
// is then G^T C^-1 G with C the dwell means' covariance for the programme's schedule, and
// it depends on the order and timing of the positions, not on the total dwell alone.
#include <Eigen/Dense>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/full_estimator.hpp"
#include "calib/parameters.hpp"
#include "calib/programs.hpp"

namespace standcal {

enum class DesignModel { invariant, full };
std::string design_model_name(DesignModel m);

// Bench timing and noise; defaults are issue 3's.
struct DesignSettings {
  double noise_density_ug_rthz = 10;
  // Bias wander per axis (docs/calibration.md "Noise model"): a first-order Gauss-Markov
  // bias of this stationary standard deviation and correlation time; 0: white noise only.
  double bias_instability_ug = 0;
  double bias_instability_tau_s = 300;
  // The correlation time known only as a range, from bias_instability_tau_s to this (what
  // `standcal noise` gives from a static recording); 0: one value. The predicted variances
  // are averaged over the range's times, as a fit given the range averages its parameters'
  // (docs/calibration.md, "Given as a range").
  double bias_instability_tau_max_s = 0;
  double dwell_s = 30;  // per position, unless the programme overrides it
  double settle_s = 5;
  double move_rate_deg_s = 10;
  double remount_s = 600;
  MountingModel mounting = MountingModel::common_fixture;
  // Where the noise figures came from, in words, when not given as figures (the unit's static
  // recording); "" otherwise. Its reader's warnings, each naming the file (a last line cut off,
  // g assumed ...): the JSON carries them beside it.
  std::string noise_from;
  std::vector<std::string> noise_from_warnings;
  bool wander() const { return bias_instability_ug > 0; }
  KnownTau wander_tau() const;  // one value, or the range
};

// Target 1 sigma for the nine unit parameters (report units).
struct AccuracyTarget {
  double bias_ug = 2;
  double scale_ppm = 2;
  double gamma_arcsec = 1;
  // Per unit parameter, internal units (g, dimensionless, rad).
  std::array<double, kUnitParameterCount> sigma_internal() const;
};
// Parses "bias=2ug,scale=2ppm,gamma=1asec" (units optional; missing keys keep defaults).
AccuracyTarget parse_accuracy_target(const std::string& text);

// The linearised model of a programme: per pose a block G_k (rows x estimated parameters)
// such that one dwell of T s at pose k adds T / N^2 * G_k^T G_k to the information.
struct DesignBasis {
  DesignModel model = DesignModel::invariant;
  std::vector<Eigen::MatrixXd> blocks;
  // Per pose, which combination of the three instrument axes each row of its block measures
  // (rows x 3): the identity for the full model, u^T for the invariant one. The wander adds
  // to the axes, so rows share it in proportion to their projections' dot product.
  std::vector<Eigen::MatrixXd> projections;
  std::vector<std::string> parameter_names;  // estimated parameters, column order
  std::array<int, kUnitParameterCount>
      unit_column{};  // column of each unit parameter, -1 if not observable
  std::array<std::string, kUnitParameterCount> unobservable_reason;
  std::vector<std::string> notes;  // what is unobservable or constrained, and why
  int columns() const { return static_cast<int>(parameter_names.size()); }
};
DesignBasis design_basis(const std::vector<StandPose>& poses, DesignModel model,
                         MountingModel mounting = MountingModel::common_fixture);

std::vector<StandPose> poses_of(const Program& program);

struct BenchTime {
  double move_s = 0, settle_s = 0, dwell_s = 0, remount_s = 0;
  double warmup_s = 0;  // the programme's warm-up (Program::warmup_s)
  int remounts = 0;
  double total_s() const { return move_s + settle_s + warmup_s + dwell_s + remount_s; }
};
// Moves run both axes at once from the previous position (the first from (0, 0)); settle
// and dwell per position (programme overrides first, then `dwell_s` if given, then settings).
BenchTime bench_time(const Program& program, const DesignSettings& settings,
                     const std::vector<double>& dwell_s = {});

// When each position's dwell runs, on bench_time's timeline (the simulator's too).
struct DwellWindow {
  double start_s = 0;
  double length_s = 0;
};
std::vector<DwellWindow> dwell_windows(const Program& program, const DesignSettings& settings,
                                       const std::vector<double>& dwell_s = {});

// Covariance of the means of two dwells under a Gauss-Markov process of unit variance and
// correlation time tau: the exact average over both windows (a dwell long against tau
// averages its own wander down, which the point-in-time approximation would miss). The
// windows are one and the same or disjoint, as a schedule's dwells are; throws
// std::invalid_argument for windows that partly overlap.
double wander_mean_covariance(const DwellWindow& a, const DwellWindow& b, double tau_s);

// The information of a programme's dwell means for `dwell_s` (programme order), white noise
// and wander: G^T C^-1 G. With white noise alone it is sum_k T_k / N^2 G_k^T G_k. With the
// wander's correlation time given as a range, the information whose inverse is the
// covariance averaged over the range's times, each variance at least the range's
// log-middle's (as a fit given the range reports).
Eigen::MatrixXd scheduled_information(const DesignBasis& basis, const Program& program,
                                      const DesignSettings& settings,
                                      const std::vector<double>& dwell_s);

// The programme's positions visited `times` times in a row (same order each pass), named
// "<name> x<times>": revisiting a position lets a fit tell the wander from the parameters.
Program repeated_program(const Program& program, int times);

struct DesignEvaluation {
  std::string program;
  DesignModel model = DesignModel::invariant;
  std::vector<std::string> parameter_names;
  Eigen::MatrixXd information;  // for the dwells and noise given, internal units
  std::array<std::optional<double>, kUnitParameterCount> unit_sigma;  // report units
  // With wander: what the sigmas would be under the white noise alone (report units).
  std::array<std::optional<double>, kUnitParameterCount> white_unit_sigma;
  std::array<std::string, kUnitParameterCount> unobservable_reason;
  double d_criterion = 0;  // det(unit-block information per unit measurement variance)^(1/9)
  double a_criterion = 0;  // trace of the unit-block covariance per unit measurement variance
  std::vector<std::string> notes;
  std::vector<double> dwell_s;
  BenchTime time;
};
DesignEvaluation evaluate_design(const Program& program, DesignModel model,
                                 const DesignSettings& settings);

// D-criterion of a basis with weights per pose (empty: one unit each): det(M_unit)^(1/9),
// where M_unit is the information of the unit parameters with nuisance ones marginalised.
// Zero when a unit parameter is unobservable.
double d_criterion(const DesignBasis& basis, const std::vector<double>& weights = {});

struct DwellPlan {
  std::vector<double> dwell_s;  // per position
  double total_dwell_s = 0;
  std::string limiting_parameter;  // the target that sets the time (equal dwell)
  bool feasible = true;            // false when the programme cannot observe a target parameter
  std::string reason;
};
// The least equal dwell per position meeting the target. White noise: from the basis
// alone (the load scales as 1 / dwell). With wander the programme's schedule matters, so
// the overloads that take it search the dwell: the least that meets the target, or
// infeasible, naming the parameter whose floor the wander sets and that floor.
DwellPlan equal_dwell_for_target(const DesignBasis& basis, const AccuracyTarget& target,
                                 const DesignSettings& settings);
DwellPlan equal_dwell_for_target(const DesignBasis& basis, const Program& program,
                                 const AccuracyTarget& target, const DesignSettings& settings);
// Dwell per position meeting the target in the least total dwell. With wander the
// allocation's shape is white noise's (minimax) and its total is searched as above.
DwellPlan allocated_dwell_for_target(const DesignBasis& basis, const AccuracyTarget& target,
                                     const DesignSettings& settings);
DwellPlan allocated_dwell_for_target(const DesignBasis& basis, const Program& program,
                                     const AccuracyTarget& target, const DesignSettings& settings);
// The least total dwell any programme on this stand could need (continuous optimal design
// over a grid of reachable poses, single mount).
double continuous_lower_bound_s(DesignModel model, const AccuracyTarget& target,
                                const DesignSettings& settings, const StandLimits& limits = {});

struct OptimizeOptions {
  int positions = 9;
  DesignModel model = DesignModel::invariant;
  bool paper_structure = false;  // 5 at alpha2 = 0, 3 at alpha1 = 0, one fixed at (45, 90)
  StandLimits limits;
  int restarts = 6;
  unsigned seed = 1;
};
struct OptimizedProgram {
  Program program;
  double d_criterion = 0;
  double paper9_d_criterion = 0;  // for comparison
  int sweeps = 0;
};
// D-optimal programme by coordinate exchange (grid scan per position, then local polish).
OptimizedProgram optimize_program(const OptimizeOptions& options);

// A programme visited `times` passes in a row, with the least equal dwell per visit that
// meets the target on its schedule.
struct RevisitPlan {
  int times = 1;
  DwellPlan equal;
  BenchTime time;
};
// Of the programme visited 1 .. max_repeats times, the plan that meets the target in the
// least bench time; none when no pass count does. `one_pass`: the programme's own plan,
// when already made.
std::optional<RevisitPlan> fastest_revisit(const Program& program, DesignModel model,
                                           const AccuracyTarget& target,
                                           const DesignSettings& settings, int max_repeats,
                                           const std::optional<RevisitPlan>& one_pass = {});

// Under bias wander, white noise's D-optimal angles are not the fastest way to a target: the
// wander the dwell means share depends on where the unit points at each moment, and white
// noise's information does not see the schedule. From `start`, a pattern search moves each
// position's angles to shorten its fastest revisit plan: at that plan's passes and dwell, the
// dwell the target needs taken as the dwell times the worst parameter's (sigma / target)^2,
// plus the moves; re-planned exactly after each round, and kept only where the exact plan is
// faster. A position moves only where the programme still estimates the parameters `start`
// does. A local search: it finds a faster programme near `start`, not the fastest; the
// visiting order stays `start`'s.
struct WanderPolish {
  Program program;  // the moved angles, named "<start>-wander", or `start` unchanged
  std::optional<RevisitPlan> plan;        // its fastest revisit
  std::optional<RevisitPlan> start_plan;  // that of `start`
  int rounds = 0;                         // rounds that shortened the exact plan
};
WanderPolish polish_for_wander(const Program& start, DesignModel model, const StandLimits& limits,
                               const AccuracyTarget& target, const DesignSettings& settings,
                               int max_repeats);

}  // namespace standcal
