#pragma once
// The model-mismatch diagnosis (calib/diagnosis/diagnosis.hpp) as a report a bench engineer reads:
// the verdict and findings in words, and figures drawn by standcal_plot — per output axis,
// the residuals against angle, time and temperature before (baseline model) and after
// (with the findings), the positions that carry the mismatch shaded, and the residual
// pattern the findings predict drawn over the data (docs/report.md).
#include <string>
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/recording.hpp"
#include "report/plot/figure.hpp"

namespace standcal::report {

// One position of the diagnosed recording, in report units (µg), before and after.
struct ResidualPoint {
  int pos = 0;
  double alpha1_deg = 0, alpha2_deg = 0;
  double t_start_s = 0, t_end_s = 0, t_mid_s = 0;
  double temp_c = 0;       // NaN when the recording has no temperature
  Vec3 up = Vec3::Zero();  // commanded gravity direction in instrument axes (u_x, u_y, u_z)
  // Per fitted component (x, y, z for the full-vector fit; the projection L for the
  // invariant one): residual and its standard error, baseline and final fit.
  std::vector<double> before_ug, before_sigma_ug, after_ug, after_sigma_ug;
  // What the findings predict the baseline leaves in its residuals (the part of their
  // signature the calibration parameters cannot absorb); zero without findings.
  std::vector<double> predicted_ug;
};

// The per-position view of a diagnosis of `rec` (the recording it was computed from).
// The predicted signature is the baseline residual minus the residual of the same
// estimator refitted to the averages with the findings' effects removed, which is exactly
// the unabsorbed part of the effects for the linearised model. Throws std::runtime_error
// when the diagnosis does not belong to the recording (position counts differ).
std::vector<ResidualPoint> residual_points(const Diagnosis& d, const Recording& rec);

// Names of the fitted components: {"x", "y", "z"} or {"L"}.
std::vector<std::string> component_names(const Diagnosis& d);

// One figure per fitted component: residuals against alpha1, alpha2, the gravity
// component along that axis (full-vector only), time, and temperature (when it was recorded
// and moved by at least 0.05 degC). Shaded spans: positions beyond 3 sigma in the baseline.
std::vector<plot::Figure> residual_figures(const Diagnosis& d,
                                           const std::vector<ResidualPoint>& points);

// A settling-transient finding: the raw samples' within-dwell residuals against the time
// since arrival, binned over all positions, with the decay the finding predicts. Empty
// when the diagnosis has no settling-transient finding.
std::vector<plot::Figure> settling_figures(const Diagnosis& d, const Recording& rec);

// The whole report: a self-contained HTML page (inline SVG, no external files).
std::string diagnosis_html(const Diagnosis& d, const Recording& rec);

}  // namespace standcal::report
