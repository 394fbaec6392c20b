#include "calib/static_noise.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "calib/norm_calibration.hpp"
#include "calib/units.hpp"

namespace standcal {

namespace {

std::string scale_words(const Vec3& ug_per_unit) {
  char b[160];
  std::snprintf(b, sizeof b, "x %.4g, y %.4g, z %.4g ug per count", ug_per_unit[0], ug_per_unit[1],
                ug_per_unit[2]);
  return b;
}

// Counts become ug by the scale the norm fit finds over the recording's static intervals (its
// orientations).
Vec3 counts_scale_from_norm_fit(const RawInput& in, const StaticNoiseOptions& o,
                                StaticDetection& detection, std::string& how) {
  NormCalibrationOptions fit;
  fit.detector = o.detector;
  fit.detector.require_orientations = true;
  fit.stability = false;
  NormCalibration c;
  try {
    c = calibrate_without_angles(in, fit);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) +
                             "; counts need a scale to be read in ug: give --counts-per-g, or " +
                             in.option("units") + " g|mps2 if the values are not counts");
  }
  const Vec3 ug_per_count = ug_per_input_unit(c.fit.compensation, in.g_mps2);
  how = "counts by the norm fit's scale over " + std::to_string(c.detection.intervals.size()) +
        " static intervals (" + scale_words(ug_per_count) + ")";
  detection = std::move(c.detection);
  return ug_per_count;
}

Vec3 physical_scale(const RawInput& in, std::string& how) {
  if (in.units == InputUnits::g) {
    how = "g (" + in.units_how + ")";
    return Vec3::Constant(1 / kUg);
  }
  char b[64];
  std::snprintf(b, sizeof b, " over g = %.6g m/s^2", in.g_mps2);
  how = "m/s^2 (" + in.units_how + ")" + b;
  return Vec3::Constant(1 / (in.g_mps2 * kUg));
}

}  // namespace

DwellAllan allan_in_ug(const StaticDetection& d, const Vec3& ug_per_unit, double sample_period_s) {
  DwellAllan out;
  out.sample_period_s = sample_period_s;
  out.segments = d.intervals.size();
  out.gaps = d.gaps;
  for (std::size_t a = 0; a < 3; ++a) {
    out.curves[a] = d.allan[a];
    for (AllanPoint& p : out.curves[a]) p.deviation *= ug_per_unit[static_cast<Eigen::Index>(a)];
    out.figures[a] = noise_figures(out.curves[a]);
  }
  return out;
}

StaticNoise static_noise(const RawInput& in, const StaticNoiseOptions& options) {
  StaticNoiseOptions o = options;
  o.detector.require_orientations = false;  // one orientation held is the classic Allan record
  if (in.format == InputFormat::means)
    throw std::runtime_error(in.source +
                             ": a table of static means has no samples to take an Allan "
                             "deviation of (give the raw recording)");
  if (o.counts_per_g && in.units != InputUnits::counts)
    throw std::invalid_argument(in.source +
                                ": a scale in counts per g is for counts, and its "
                                "values were read as " +
                                std::string(to_string(in.units)) + " (" + in.units_how + ")");
  StaticNoise n;
  StaticDetection d;
  if (in.units == InputUnits::counts && !o.counts_per_g) {
    n.ug_per_unit = counts_scale_from_norm_fit(in, o, d, n.units_how);
  } else {
    d = detect_static_intervals(in, o.detector);
    if (in.units == InputUnits::counts) {
      n.ug_per_unit = Vec3::Constant(1 / (*o.counts_per_g * kUg));
      n.units_how = "counts by the given scale (" + scale_words(n.ug_per_unit) + ")";
    } else {
      n.ug_per_unit = physical_scale(in, n.units_how);
    }
  }
  if (d.intervals.empty())
    throw std::runtime_error(in.source + ": no static interval found (" + d.how +
                             "): the unit never stayed still long enough");
  n.intervals_how = d.how;
  const double period_s = 1.0 / in.sample_rate_hz;
  for (const StaticInterval& iv : d.intervals) {
    n.samples += iv.end - iv.begin;
    n.longest_s = std::max(n.longest_s, static_cast<double>(iv.end - iv.begin) * period_s);
  }
  if (n.samples < kMinAllanSamples)
    throw std::runtime_error(in.source + ": " + std::to_string(n.samples) +
                             " static samples are too few for an Allan deviation (at least " +
                             std::to_string(kMinAllanSamples) + ")");
  n.allan = allan_in_ug(d, n.ug_per_unit, period_s);
  return n;
}

}  // namespace standcal
