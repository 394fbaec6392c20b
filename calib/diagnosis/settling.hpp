#pragma once
// Settling transients (docs/diagnosis.md step 6), tested on the raw samples inside each
// dwell: invisible in the per-position means when the same at every position.
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/position_average.hpp"
#include "calib/recording.hpp"

namespace standcal::diagnosis {

struct SettlingResult {
  int axis = 0;
  double tau_s = 0, amplitude_ug = 0, sigma_ug = 0, delta_chi2 = 0, press_gain = 0;
  // sigma of the amplitude when tau is estimated too (from the same samples): the
  // amplitude and tau are correlated, and the reported sigma must carry that.
  double sigma_free_tau_ug = 0;
  std::vector<double> mean_shape;  // per position: dwell mean of exp(-(t - t_arrive) / tau)
};

// Per axis and tau: within-dwell residuals (sample - position mean) regressed on the
// de-meaned exp(-(t - t_arrive)/tau) together with a de-meaned linear trend (which a
// bias drift leaves inside a dwell, and which must not count as a transient). A third
// column, the shape's derivative by tau, gives the amplitude's sigma with tau free.
SettlingResult settling_search(const Recording& rec, const std::vector<PositionAverage>& avg,
                               int axis, double tau_s);

// The best transient of each axis (tau grid, then refined), tested like a term: the
// candidate lines go to `tests`, the significant transients are returned.
std::vector<SettlingResult> settling_findings(const Recording& rec,
                                              const std::vector<PositionAverage>& avg,
                                              const DiagnoseOptions& options,
                                              std::vector<CandidateTest>& tests);

// A significant transient as a finding, explained.
Finding settling_finding(const SettlingResult& s);

// The position means with the transients' dwell means taken out.
void remove_settling(std::vector<PositionAverage>& avg, const std::vector<SettlingResult>& found);

}  // namespace standcal::diagnosis
