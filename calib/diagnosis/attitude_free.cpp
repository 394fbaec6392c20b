// Diagnosis of recordings without angles: the norm fit's intervals as the dwells of a
// recording, and the options that make the diagnosis treat them as placed, not driven.
#include <algorithm>
#include <limits>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/wander.hpp"
#include "calib/identifiability.hpp"

namespace standcal {

namespace {

// The largest bias-instability figure of the intervals' Allan deviation, ug; 0 if none.
double allan_floor_ug(const NoiseFinding& n) {
  double floor = 0;
  if (n.allan)
    for (const NoiseFigures& f : n.allan->figures)
      floor = std::max(floor, f.bias_instability.value_or(0));
  return floor;
}

// The noise finding with the recording's Allan figures, and the understatement of
// sigma/sqrt(n) counting the colour inside each interval as well as the wander between.
void report_norm_noise(Diagnosis& d, const NormCalibration& cal,
                       const std::vector<StaticInterval>& intervals, double g) {
  d.noise.allan = cal.fit.result.noise.allan;
  d.noise.understated_by = white_noise_understatement(intervals, cal.fit.compensation, g, d.noise);
  for (std::string& s : d.summary)
    if (s.rfind("Noise:", 0) == 0) s = diagnosis::noise_words(d.noise);
}

}  // namespace

Recording calibrated_recording(const RawInput& in, const NormCalibration& cal) {
  if (in.size() == 0)
    throw CannotFit(in.source +
                    ": a table of means has no samples; the diagnosis tests "
                    "settling and whiteness on the samples of each interval");
  const NormCompensation& k = cal.fit.compensation;
  const std::vector<StaticInterval>& intervals = cal.detection.intervals;
  const std::vector<PositionAverage> avg = calibrated_averages(intervals, k, in.g_mps2);
  Recording rec;
  rec.source = in.source;
  rec.g_local_mps2 = in.g_mps2;
  rec.g_from_header = in.g_given;
  rec.sample_rate_hz = in.sample_rate_hz;
  rec.settle_s = 0;
  rec.program = "attitude-free (" + std::to_string(intervals.size()) + " static intervals)";
  rec.columns.alpha_measured = false;
  rec.columns.temp = false;
  rec.columns.t_arrive = true;
  // What its run was made with, as the norm fit of it took it (take_header_wander).
  if (in.recording) rec.unit_wander = in.recording->unit_wander;
  for (std::size_t p = 0; p < intervals.size(); ++p) {
    for (std::size_t i = intervals[p].begin; i < intervals[p].end; ++i) {
      RecordingSample s;
      s.t_s = in.t_s[i];
      s.pos = static_cast<int>(p);
      s.alpha1_cmd_deg = avg[p].alpha1_cmd_deg;
      s.alpha2_cmd_deg = avg[p].alpha2_cmd_deg;
      s.f_mps2 = k.matrix * (in.sample(i) - k.bias);
      s.t_arrive_s = intervals[p].t_start_s;
      rec.samples.push_back(s);
    }
  }
  return rec;
}

Diagnosis diagnose_without_angles(const RawInput& in, const NormCalibration& cal,
                                  DiagnoseOptions options) {
  const Recording rec = calibrated_recording(in, cal);
  options.attitude_free = true;
  options.dwell_standard_error_g.clear();
  // The norm fit weighs the intervals beside the wander it found (errors_beside_wander), but
  // the diagnosis tests against a wander of its own, which may be none, so it takes their
  // curve errors whole (conservative where it does find one).
  std::vector<StaticInterval> intervals = cal.detection.intervals;
  take_curve_errors(intervals);
  for (const PositionAverage& p : calibrated_averages(intervals, cal.fit.compensation, in.g_mps2))
    options.dwell_standard_error_g.push_back(p.standard_error_g);
  // The unit's grade from its own Allan floor: the plausible sizes of the catalog's terms.
  const double floor_ug = allan_floor_ug(cal.fit.result.noise);
  if (options.plausible_size_factor == 1)
    options.plausible_size_factor = std::max(1.0, floor_ug / kNavigationGradeAllanFloor_ug);
  // No class of unit bounds the wander of a unit nobody specified: it is believed when the
  // revisits agree with it (wander.cpp), and a jump or a knock is left to the step and
  // outlier checks.
  options.max_bias_instability_ug = std::numeric_limits<double>::infinity();
  Diagnosis d = diagnose_recording(rec, options);
  report_norm_noise(d, cal, intervals, in.g_mps2);
  return d;
}

}  // namespace standcal
