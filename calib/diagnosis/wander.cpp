#include "calib/diagnosis/wander.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "calib/diagnosis/words.hpp"
#include "calib/text.hpp"
#include "calib/units.hpp"

namespace standcal::diagnosis {

namespace {

constexpr double kAttitudeFreeSamePose_deg = 2;

// Terms that vary slowly with time (directly, through temperature, or through the order
// of the moves): the shapes a wander realisation can mimic.
bool slow_in_time(const Candidate& c) {
  static const char* const kSlow[] = {"bias_drift", "bias_temperature", "scale_temperature",
                                      "hysteresis", "stand_level_drift"};
  return std::any_of(std::begin(kSlow), std::end(kSlow),
                     [&c](const char* id) { return c.effect() == id; });
}

Selection select_under(Prepared& P, const GaussMarkovNoise& noise, const DiagnoseOptions& options) {
  P.model->use_noise(noise);
  const LinearProblem& lp = P.model->problem();
  P.base = solve_linear(lp.A, lp.y, lp.row_position, lp.positions);
  return forward_selection(*P.model, P.ctx, P.cands, P.untestable, P.implausible, P.base, options);
}

// The rows a wander is estimated from, with the whitened design and measurements it is
// estimated under: what another wander (the unit's specified one) is weighed against.
struct WanderProblem {
  std::vector<NoiseRow> rows;
  Eigen::MatrixXd X;
  Eigen::VectorXd y;
};

// A wander estimated from a run, and the problem it was estimated from.
struct RunWander {
  NoiseEstimate estimate;
  WanderProblem problem;
};

RunWander estimate_from(WanderProblem problem, const NoiseEstimateOptions& o) {
  NoiseEstimate e = estimate_bias_wander(problem.rows, problem.X, problem.y, o);
  return {std::move(e), std::move(problem)};
}

// The rows of the positions whose pose the programme visits more than once, with a free
// mean per pose and row component, and the slow terms' columns on those rows.
struct BetweenVisits {
  std::vector<Eigen::Index> rows;
  WanderProblem problem;
};

// Positions whose up-vectors agree within `tolerance_rad` are one pose: exactly, for a stand's
// commanded angles; within kAttitudeFreeSamePose_deg for a unit placed by hand, whose
// pose-dependent physics changes by its gradient times that angle at most.
std::vector<int> pose_index(const std::vector<PositionContext>& ctx, double tolerance_rad) {
  std::vector<int> pose(ctx.size(), -1);
  int n = 0;
  for (std::size_t k = 0; k < ctx.size(); ++k) {
    for (std::size_t j = 0; j < k && pose[k] < 0; ++j)
      if ((ctx[j].up - ctx[k].up).norm() < tolerance_rad) pose[k] = pose[j];
    if (pose[k] < 0) pose[k] = n++;
  }
  return pose;
}

BetweenVisits between_visits(const Prepared& P, const std::vector<Candidate>& slow,
                             double tolerance_rad) {
  const LinearProblem& lp = P.model->problem();
  const std::vector<int> pose = pose_index(P.ctx, tolerance_rad);
  std::vector<int> visits(P.ctx.size(), 0);
  for (int p : pose) ++visits[static_cast<std::size_t>(p)];
  BetweenVisits bv;
  std::vector<std::pair<int, int>> column_of;  // (pose, component) of each mean column
  std::vector<int> row_column;
  for (std::size_t r = 0; r < lp.row_position.size(); ++r) {
    const int p = pose[static_cast<std::size_t>(lp.row_position[r])];
    if (visits[static_cast<std::size_t>(p)] < 2) continue;
    const std::pair<int, int> key{p, lp.row_component[r]};
    auto it = std::find(column_of.begin(), column_of.end(), key);
    if (it == column_of.end()) it = column_of.insert(column_of.end(), key);
    row_column.push_back(static_cast<int>(it - column_of.begin()));
    bv.rows.push_back(static_cast<Eigen::Index>(r));
    bv.problem.rows.push_back(lp.noise_rows[r]);
  }
  if (bv.rows.empty()) return bv;
  const Eigen::MatrixXd slow_cols =
      with_columns(Eigen::MatrixXd(lp.y.size(), 0), term_columns_white(*P.model, P.ctx, slow));
  const auto m = static_cast<Eigen::Index>(bv.rows.size());
  const auto means = static_cast<Eigen::Index>(column_of.size());
  Eigen::MatrixXd& X = bv.problem.X;
  X = Eigen::MatrixXd::Zero(m, means + slow_cols.cols());
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::Index r = bv.rows[static_cast<std::size_t>(i)];
    X(i, row_column[static_cast<std::size_t>(i)]) =
        1.0 / lp.row_sigma_g[static_cast<std::size_t>(r)];
    // Without a slow term there is nothing to copy, and a matrix without columns has no
    // storage: taking a row of it offsets a null pointer (undefined behaviour).
    if (slow_cols.cols() > 0) X.row(i).tail(slow_cols.cols()) = slow_cols.row(r);
  }
  bv.problem.y = lp.y_white(bv.rows);
  return bv;
}

// A unit placed by hand seldom repeats a pose, so there are no revisits to take the
// wander from: it is estimated from every interval with the calibration and every testable
// catalog term free, so that no term the catalog knows can pass for noise.
RunWander wander_with_every_term(const Prepared& P, const NoiseEstimateOptions& o) {
  std::vector<Candidate> testable;
  for (std::size_t i = 0; i < P.cands.size(); ++i)
    if (P.untestable[i].empty() && P.cands[i].entry->test == CatalogTest::columns)
      testable.push_back(P.cands[i]);
  const LinearProblem& lp = P.model->problem();
  RunWander w = estimate_from(
      {lp.noise_rows, with_columns(lp.A_white, term_columns_white(*P.model, P.ctx, testable)),
       lp.y_white},
      o);
  w.estimate.how = "from all " + std::to_string(lp.positions) +
                   " intervals with the calibration and " + std::to_string(testable.size()) +
                   " testable catalog terms free; " + w.estimate.how;
  return w;
}

// A unit placed by hand revisits only some orientations, and only roughly, so the revisits
// alone seldom pin the wander. It is estimated from every interval, with the calibration
// and the slow terms free, and believed only if the revisits support it better than white
// noise: a pattern that depends on the pose (a K2, a cross-coupling) inflates that
// estimate, but repeated orientations agree with each other whatever pose-dependent
// physics there is, so they then prefer no wander. Without revisits every testable term is
// held free instead.
RunWander attitude_free_wander(const Prepared& P, const std::vector<Candidate>& slow,
                               const BetweenVisits& bv, const NoiseEstimateOptions& o) {
  if (bv.rows.empty()) return wander_with_every_term(P, o);
  const LinearProblem& lp = P.model->problem();
  RunWander w = estimate_from(
      {lp.noise_rows, with_columns(lp.A_white, term_columns_white(*P.model, P.ctx, slow)),
       lp.y_white},
      o);
  NoiseEstimate& all = w.estimate;
  all.how = "from all " + std::to_string(lp.positions) +
            " intervals with the calibration and the slow terms free; " + all.how;
  if (!all.significant) return w;
  const WanderProblem& revisits = bv.problem;
  const double support =
      2 * (restricted_log_likelihood(revisits.rows, revisits.X, revisits.y, all.noise) -
           restricted_log_likelihood(revisits.rows, revisits.X, revisits.y, GaussMarkovNoise{}));
  all.how += "; the " + std::to_string(bv.rows.size()) + " revisits of repeated orientations " +
             (support > 0 ? "support" : "do not support") +
             " it against white noise (2 delta log L = " + fmt("%.1f", support) + ")";
  if (!(support > 0)) {
    all.significant = false;
    all.noise = GaussMarkovNoise{};
  }
  return w;
}

// The run's wander, where it is a finding and the unit's is given with its correlation time,
// gives way to the unit's unless the run departs from it: the rule the fits weigh with
// (noise_model.hpp, run_agrees_with_specified), so that a recording's diagnosis and its fit
// test and weigh against the same wander. Returns whether it gave way.
bool weigh_as_specified_where_agreeing(RunWander& w, const DiagnoseOptions& options) {
  if (!w.estimate.significant || options.specified_wander.white() || !options.known_tau)
    return false;
  FitNoiseOptions given;
  given.specified = options.specified_wander;
  given.known_tau = options.known_tau;
  if (!run_agrees_with_specified(w.problem.rows, w.problem.X, w.problem.y, given, w.estimate))
    return false;
  w.estimate.noise = specified_at_known_tau(given);
  return true;
}

}  // namespace

DiagnoseOptions with_unit_wander(DiagnoseOptions options, const Recording& rec,
                                 const std::optional<AllanFinding>& allan) {
  FitNoiseOptions fit;
  fit.specified = options.specified_wander;
  fit.known_tau = options.known_tau;
  if (!take_unit_wander(fit, rec, allan, options.unit_static_tau_floor_s)) return options;
  options.specified_wander = fit.specified;
  options.known_tau = fit.known_tau;
  options.specified_wander_from = fit.specified_from;
  return options;
}

NoiseAndTerms select_terms_and_noise(Prepared& P, const DiagnoseOptions& options) {
  // The wander is estimated from the positions the programme visits more than once, with
  // each pose's mean free (one column per pose and row component) and every testable slow
  // term in the model: what is left is the between-visit scatter (model.md
  // bias_instability). Anything that depends on the pose alone, known to the catalog or not,
  // cancels there and cannot be taken for noise; a real drift or temperature coefficient
  // stays a column. When the wander is significant the terms are selected under it
  // (generalised least squares), so that a wander realisation is not taken for a drift.
  std::vector<Candidate> slow;
  for (std::size_t i = 0; i < P.cands.size(); ++i)
    if (P.untestable[i].empty() && slow_in_time(P.cands[i])) slow.push_back(P.cands[i]);
  NoiseEstimateOptions o;
  o.lr_threshold = options.wander_lr_threshold;
  if (options.known_tau) o.tau_grid_s = options.known_tau->grid_s();
  const double tolerance_rad = options.attitude_free ? kAttitudeFreeSamePose_deg * kDegToRad : 1e-9;
  const BetweenVisits bv = between_visits(P, slow, tolerance_rad);
  const auto estimate = [&](const NoiseEstimateOptions& on_grid) {
    RunWander r;
    if (options.attitude_free) {
      r = attitude_free_wander(P, slow, bv, on_grid);
    } else if (bv.rows.size() > 0) {
      r = estimate_from(bv.problem, on_grid);
    } else {
      r.estimate.how = "not estimated: no position is visited twice";
    }
    return r;
  };
  RunWander run = estimate(o);
  NoiseAndTerms out;
  // A floor under the correlation time stands only where these rows show the wander under it,
  // as the fits' (choose_fit_noise): curves cannot tell a slow wander from a settling.
  if (options.known_tau && options.known_tau->open_above && !run.estimate.significant) {
    o.tau_grid_s = NoiseEstimateOptions{}.tau_grid_s;
    run = estimate(o);
    run.estimate.how += tau_floor_set_aside_words(options.known_tau->min_s);
    out.tau_floor_set_aside = true;
  } else if (options.known_tau) {
    run.estimate.how += "; at " + options.known_tau->words();
  }
  NoiseEstimate& e = run.estimate;
  if (e.significant && e.noise.q_g.maxCoeff() > options.max_bias_instability_ug * kUg) {
    const double wander_ug = e.noise.q_g.maxCoeff() / kUg;  // the size judged
    e.significant = false;
    e.noise = GaussMarkovNoise{};
    const auto [wander, most] = fixed_texts_apart(wander_ug, options.max_bias_instability_ug, 1);
    e.how += "; not taken as noise: " + wander +
             " ug is beyond the bias instability of this class of unit (" + most + " ug)";
  }
  out.weighted_as_specified = weigh_as_specified_where_agreeing(run, options);
  out.noise = std::move(e);
  if (!out.noise.significant && !options.specified_wander.white()) {
    out.noise.noise = options.specified_wander;
    out.noise.how += "; the tests use the unit's specified wander instead";
  }
  out.selection = select_under(P, out.noise.noise, options);
  return out;
}

namespace {

// "given; ", "within the given 400-900 s; " or nothing: where the correlation time came from.
std::string tau_given_words(const NoiseFinding& n) {
  if (n.tau_given_open_above)
    return "from " + fmt("%.0f", n.tau_given_max_s > 0 ? n.tau_given_min_s : n.tau_s) +
           " s up, by a long static stretch's Allan curves, which see a wander they do not pin; ";
  if (n.tau_given_max_s > 0)
    return "within the given " + fmt("%.0f", n.tau_given_min_s) + "-" +
           fmt("%.0f", n.tau_given_max_s) + " s; ";
  return n.tau_given ? "given; " : "";
}

// " (the middle of the given 400-900 s)": the correlation time a range was weighed at.
std::string middle_of_range_words(const NoiseFinding& n) {
  if (n.tau_given_open_above)
    return " (the middle of " + fmt("%.0f", n.tau_given_min_s) + "-" +
           fmt("%.0f", n.tau_given_max_s) +
           " s: from the shortest a long static stretch's Allan curves allow to the longest the "
           "fits model)";
  return std::string(n.unit_wander_from == kWanderFromRecording
                         ? " (the middle of the long dwell's "
                     : n.unit_wander_from == kWanderFromStaticRecording
                         ? " (the middle of the unit's static recording's "
                         : " (the middle of the given ") +
         fmt("%.0f", n.tau_given_min_s) + "-" + fmt("%.0f", n.tau_given_max_s) + " s)";
}

// Whose wander the terms are tested against, where it is the unit's.
std::string unit_wander_words(const NoiseFinding& n) {
  return n.unit_wander_from == kWanderFromRecording
             ? "the unit's wander as this recording's long dwell shows it (its Allan curves)"
         : n.unit_wander_from == kWanderFromStaticRecording
             ? "the unit's wander as its static recording shows it (its Allan curves)"
         : n.unit_wander_from == kWanderFromHeader
             ? "the unit's given wander its run was made with (the recording's header)"
             : "the unit's given wander";
}

}  // namespace

std::string noise_words(const NoiseFinding& n) {
  if (n.model == "gauss_markov" && !n.bias_instability)
    return "Noise: this run does not show bias wander by itself (2 delta log L = " +
           fmt("%.1f", n.lr) + " of " + fmt("%.1f", n.lr_threshold) +
           " needed), so the terms are tested against " + unit_wander_words(n) +
           ", Gauss-Markov up to " + fmt("%.1f", n.wander_ug.maxCoeff()) +
           " ug with correlation time " + fmt("%.0f", n.tau_s) + " s" +
           (n.tau_given_max_s > 0 ? middle_of_range_words(n) : "") +
           " (generalised least squares): a drift or temperature term must stand out from "
           "what that wander can do in this run.";
  if (!n.bias_instability) return "";
  if (n.source == "specified")
    return "Noise: the dwell means wander more than their white-noise errors allow (bias "
           "instability, a noise finding, not missing physics), and by as much as " +
           unit_wander_words(n) + ": Gauss-Markov up to " + fmt("%.1f", n.wander_ug.maxCoeff()) +
           " ug with correlation time " + fmt("%.0f", n.tau_s) + " s" +
           (n.tau_given_max_s > 0 ? middle_of_range_words(n) : " (given)") +
           ", which every test above weighs the positions with (generalised least squares; 2 "
           "delta log L = " +
           fmt("%.0f", n.lr) + " against white noise).";
  std::string s =
      "Noise: the dwell means wander more than their white-noise errors allow (bias instability, a "
      "noise "
      "finding, not missing physics): Gauss-Markov";
  for (int a = 0; a < 3; ++a)
    s +=
        std::string(a ? "," : "") + " " + kAxisNames[a] + " " + fmt("%.1f", n.wander_ug[a]) + " ug";
  s += specified_axes_words(n) + ", correlation time " + fmt("%.0f", n.tau_s) + " s (" +
       tau_given_words(n) + "Allan floor";
  for (int a = 0; a < 3; ++a)
    s += std::string(a ? "," : "") + " " + fmt("%.1f", n.allan_peak_ug[a]);
  s += " ug); sigma/sqrt(n) understated a dwell mean's error by up to " +
       fmt("%.1f", n.understated_in_total().maxCoeff()) +
       "x. Every test above weighs the positions with this noise "
       "(generalised least squares; 2 delta log L = " +
       fmt("%.0f", n.lr) + ").";
  return s;
}

}  // namespace standcal::diagnosis

namespace standcal {

void DiagnoseOptions::give_static_recording_wander(const GivenWander& w) {
  specified_wander = w.specified();
  known_tau = w.known_tau;
  specified_wander_from = kWanderFromStaticRecording;
}

}  // namespace standcal
