#pragma once
// A residual model: what the term selection works on. It fits the baseline to position
// averages, linearises it (whitened residuals y and whitened design A, rows grouped by
// position) and says how a catalog term or a new pose would add rows. Two models today:
// the full vector J (3 rows per position, fit_full_vector) and the paper's invariant
// projection u^T J - 1 (1 row, fit_invariant_joint); an attitude-free model (|J| - 1)
// plugs in the same way.
#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "calib/diagnosis/catalog.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/fit_result.hpp"
#include "calib/full_estimator.hpp"
#include "calib/noise_model.hpp"

namespace standcal::diagnosis {

// The baseline linearised around its fit: whitened residuals y and whitened design A.
// Candidate terms are added as further columns; rows are grouped by position.
struct LinearProblem {
  Eigen::VectorXd y;
  Eigen::MatrixXd A;
  std::vector<int> unit_column;  // column of A for each of the 9 unit parameters, or -1
  std::vector<double> row_sigma_g;
  std::vector<int> row_position;
  std::vector<int> row_component;  // 0 .. rows_per_position - 1
  int positions = 0;
  // The noise the rows are weighted with (calib/noise_model): white unless the recording
  // shows bias wander. y and A (and every candidate column) are then its decorrelated form,
  // i.e. generalised least squares; y_white and A_white keep the per-dwell whitening alone.
  GaussMarkovNoise noise;
  std::vector<NoiseRow> noise_rows;
  Eigen::VectorXd y_white;
  Eigen::MatrixXd A_white;
};

// Decorrelates whitened columns of the problem's rows under its noise (identity for white).
Eigen::MatrixXd decorrelated(const LinearProblem& lp, const Eigen::MatrixXd& whitened);

class ResidualModel {
 public:
  virtual ~ResidualModel() = default;

  // The JSON `method`: "full", "joint" or "norm".
  virtual std::string name() const = 0;
  // For sentences: "full-vector", "invariant".
  virtual std::string words() const = 0;
  virtual int rows_per_position() const = 0;
  // A row component for the structure tests ("x", "L") and for sentences ("x output").
  virtual std::string component_name(int component) const = 0;
  virtual std::string component_words(int component) const = 0;
  // Why the model cannot see an entry's physics at all (catalog.hpp invariant_visible), in
  // words, or empty when it can.
  virtual std::string unseen_reason(const CatalogEntry& entry) const = 0;
  bool sees(const CatalogEntry& entry) const { return unseen_reason(entry).empty(); }
  // A contribution to J (3 x k, g) at a position as this model's rows
  // (rows_per_position x k, g): how the model projects J.
  virtual Eigen::MatrixXd project(const Eigen::MatrixXd& effect_g,
                                  const PositionContext& p) const = 0;
  // The baseline design rows a new pose would add, whitened by sigma_g.
  virtual Eigen::MatrixXd pose_rows(const StandPose& pose, double sigma_g) const = 0;
  // The same model fitted to corrected averages (same positions, same design).
  virtual std::unique_ptr<ResidualModel> refit(
      const std::vector<PositionAverage>& corrected) const = 0;

  const FitResult& fit() const { return fit_; }
  const LinearProblem& problem() const { return lp_; }
  // Weight the rows with this noise from now on (white: back to per-dwell weights).
  void use_noise(const GaussMarkovNoise& noise);

 protected:
  FitResult fit_;
  LinearProblem lp_;
};

// The full vector when its fit has redundancy, the invariant projection otherwise; for an
// attitude-free recording, |f| - g (the invariant projection on the measured direction).
// Throws CannotFit when not even the invariant calibration can be fitted.
std::unique_ptr<ResidualModel> choose_residual_model(const std::vector<PositionAverage>& avg,
                                                     bool attitude_free = false);

// The rows (g) a candidate adds at a position, whitened by sigma_g: rows_per_position x params.
Eigen::MatrixXd candidate_rows(const ResidualModel& model, const Candidate& c,
                               const PositionContext& p, double sigma_g);
// The candidate's columns for the model's problem (rows of A x params): whitened by each
// row's sigma, and decorrelated under the problem's noise unless `white_only`.
Eigen::MatrixXd candidate_columns(const Candidate& c, const ResidualModel& model,
                                  const std::vector<PositionContext>& ctx, bool white_only = false);
// Several terms' columns whitened by sigma only, in order (for the noise estimate and for a
// part of the run decorrelated on its own).
std::vector<Eigen::VectorXd> term_columns_white(const ResidualModel& model,
                                                const std::vector<PositionContext>& ctx,
                                                const std::vector<Candidate>& terms);
// Every candidate's columns side by side.
Eigen::MatrixXd all_candidate_columns(const std::vector<Candidate>& cands,
                                      const ResidualModel& model,
                                      const std::vector<PositionContext>& ctx);

}  // namespace standcal::diagnosis
