// The reader of recordings from anywhere (calib/raw_input.hpp: standcal's own format, imu_tk
// text, delimited text with a header, tables of static means) and what the attitude-free
// commands do with what it read: `standcal fit --method norm` (static intervals, the norm
// fit, its threshold refits, JSON and report), `standcal diagnose` of a recording without
// angles, and `standcal noise` (the pooled Allan deviation and its Gauss-Markov fit).
//
// Input: two bytes of reading options, then the file's text. Byte 0: format (low 3 bits,
// mod 5: auto, standcal, imu_tk, delimited, means) and units (bits 3-4: auto, counts, g,
// mps2); byte 1: bit 0 a sample rate is given (bits 1-2 pick 1, 10, 100 or 400 Hz), bits
// 3-4 preamble lines to skip, bit 5 local gravity given (9.81), bit 6 the axis columns
// given as 2,3,4 and bit 7 as ax,ay,az. Two zero bytes read as the command line with no
// option.
//
// Properties: the reader accepts with its format and units decided, one time and three
// axis values per sample, every value finite (an accelerometer's within 1e12, a time within
// 1e12 s) and time never going backwards, a rate above 0 and at most 1e6 Hz or unknown
// (NaN); or refuses with a
// RecordingError / std::runtime_error. A calibration reports finite values and sigmas
// that are finite and not negative, serialises, and reports in words; a diagnosis gives
// one of its verdicts with finite findings; the Allan curves are finite.
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/allan.hpp"
#include "calib/json_text.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/raw_input.hpp"
#include "calib/static_noise.hpp"
#include "fuzz/targets/diagnosis_checks.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace {

using standcal::fuzz::require;

standcal::InputOptions options_of(std::uint8_t b0, std::uint8_t b1) {
  using namespace standcal;
  static const InputFormat kFormats[] = {InputFormat::automatic, InputFormat::standcal,
                                         InputFormat::imu_tk, InputFormat::delimited,
                                         InputFormat::means};
  static const InputUnits kUnits[] = {InputUnits::automatic, InputUnits::counts, InputUnits::g,
                                      InputUnits::mps2};
  static const double kRates[] = {1, 10, 100, 400};
  InputOptions o;
  o.format = kFormats[(b0 & 7) % 5];
  o.units = kUnits[(b0 >> 3) & 3];
  if (b1 & 1) o.rate_hz = kRates[(b1 >> 1) & 3];
  o.skip_lines = (b1 >> 3) & 3;
  if (b1 & 0x20) o.g_mps2 = 9.81;
  if (b1 & 0x40) o.columns = {"2", "3", "4"};
  if (b1 & 0x80) o.columns = {"ax", "ay", "az"};
  return o;
}

void check_read(const standcal::RawInput& in) {
  using namespace standcal;
  require(in.format != InputFormat::automatic, "raw_input: accepted with the format undecided");
  require(in.units != InputUnits::automatic, "raw_input: accepted with the units undecided");
  require(std::isfinite(in.g_mps2) && in.g_mps2 > 0, "raw_input: local gravity not positive");
  const std::size_t n = in.t_s.size();
  for (const auto& axis : in.axis)
    require(axis.size() == n, "raw_input: an axis holds " + std::to_string(axis.size()) +
                                  " values for " + std::to_string(n) + " times");
  require(in.block.empty() || in.block.size() == n, "raw_input: dwell blocks not one per sample");
  for (std::size_t i = 0; i < n; ++i) {
    require(std::abs(in.t_s[i]) <= kMaxAbsTime_s &&
                is_plausible_accelerometer_value(in.axis[0][i]) &&
                is_plausible_accelerometer_value(in.axis[1][i]) &&
                is_plausible_accelerometer_value(in.axis[2][i]),
            "raw_input: sample " + std::to_string(i) +
                " has a time beyond 1e12 s or a value beyond any accelerometer's output");
    require(i == 0 || in.t_s[i] >= in.t_s[i - 1],
            "raw_input: time goes backwards at sample " + std::to_string(i));
  }
  // NaN: no rate known (one sample and no header or --rate-hz), which the detector refuses.
  require(std::isnan(in.sample_rate_hz) || is_plausible_sample_rate(in.sample_rate_hz),
          "raw_input: a sample rate outside [1e-12, 1e6] Hz");
  for (const StaticMeanRow& row : in.means)
    require(row.mean.cwiseAbs().maxCoeff() <= kMaxAbsAccelerometerValue &&
                (!row.samples || (*row.samples > 0 && *row.samples <= 1e12)) &&
                (!row.standard_error || row.standard_error->allFinite()),
            "raw_input: a means row (line " + std::to_string(row.line) +
                ") is not finite or its sample count beyond 1e12");
}

void check_calibration(const standcal::NormCalibration& c, const standcal::RawInput& in) {
  const standcal::NormFit& fit = c.fit;
  require(fit.compensation.bias.allFinite() && fit.compensation.matrix.allFinite(),
          "norm fit: the compensation is not finite");
  for (int i = 0; i < fit.sigma.size(); ++i)
    require(std::isfinite(fit.sigma[i]) && fit.sigma[i] >= 0,
            "norm fit: sigma " + std::to_string(i) + " is not finite or negative");
  for (const auto& p : fit.result.unit)
    if (p.value)
      require(std::isfinite(*p.value) && p.sigma && std::isfinite(*p.sigma) && *p.sigma >= 0,
              "norm fit: a reported parameter or its sigma is not finite");
  (void)standcal::json_text(
      standcal::norm_calibration_to_json(c, in));  // as `fit --json` prints it
  require(!standcal::format_norm_report(c, in).empty(), "norm fit: an empty report");
}

void check_noise(const standcal::StaticNoise& n) {
  require(n.samples > 0 && std::isfinite(n.longest_s), "noise: no static samples reported");
  for (const auto& curve : n.allan.curves)
    for (const auto& p : curve)
      require(std::isfinite(p.tau_s) && std::isfinite(p.deviation) && p.deviation >= 0,
              "noise: an Allan point is not finite");
  const auto& c = n.allan.curves;
  (void)standcal::fit_gauss_markov_allan({c[0], c[1], c[2]}, n.allan.sample_period_s);
}

}  // namespace

int standcal_fuzz_raw_input(const std::uint8_t* data, std::size_t size) {
  using namespace standcal;
  if (size < 2) return 0;
  const InputOptions options = options_of(data[0], data[1]);
  const std::string_view text = fuzz::as_text(data + 2, size - 2);
  std::optional<RawInput> in;
  fuzz::expect_only_runtime_errors("raw_input",
                                   [&] { in = parse_input(text, "fuzz-input", options); });
  if (!in) return 0;
  check_read(*in);
  std::optional<NormCalibration> calibration;
  fuzz::expect_only_runtime_errors("norm fit",
                                   [&] { calibration = calibrate_without_angles(*in); });
  if (calibration) check_calibration(*calibration, *in);
  if (in->format == InputFormat::means) return 0;
  if (calibration)
    fuzz::expect_only_runtime_errors("diagnosis", [&] {
      fuzz::check_diagnosis_output(diagnose_without_angles(*in, *calibration));
    });
  fuzz::expect_only_runtime_errors("noise", [&] { check_noise(static_noise(*in)); });
  return 0;
}
