// The estimators and the model-mismatch diagnosis on small synthetic recordings: 0 to 13
// positions at angles from a coarse grid (so repeats, collinear and all-equal programmes
// are common) or anywhere, on one or several mounts, 2 to 17 samples each, noise from none
// (a zero-variance dwell) to large, optional temperature, a small unit error. Every fit
// and the diagnosis must either answer or refuse with a std::runtime_error
// (CannotFit names the counts; issue 14: an empty QR took the daemon down); a reported
// value is finite, a reported sigma finite and not negative, and a diagnosis that checks
// the model has more distinct orientations than the nine unknowns.
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/full_estimator.hpp"
#include "calib/identifiability.hpp"
#include "calib/invariant_estimator.hpp"
#include "fuzz/targets/diagnosis_checks.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace {

using standcal::fuzz::require;

// Reads the input a byte at a time; past its end every byte is 0.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t next() { return at_ < size_ ? data_[at_++] : 0; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

// A deterministic uniform noise in [-1, 1] (no dependence on libc's rand).
class Noise {
 public:
  explicit Noise(std::uint32_t seed) : state_(seed | 1u) {}
  double next() {
    state_ ^= state_ << 13;
    state_ ^= state_ >> 17;
    state_ ^= state_ << 5;
    return static_cast<double>(state_) / 2147483647.5 - 1.0;
  }

 private:
  std::uint32_t state_;
};

double angle_deg(std::uint8_t b) {
  static const double kGrid[] = {0, 90, 180, -90, 45, 135, 72, 144, 216, 288, 30, 60};
  return b < 192 ? kGrid[b % 12] : (b - 192) * 360.0 / 64.0 - 180.0;
}

standcal::Recording synthetic_recording(ByteReader& in) {
  using namespace standcal;
  Recording rec;
  rec.source = "fuzz-diagnosis";
  rec.g_from_header = true;
  rec.settle_s = 5;
  rec.sample_rate_hz = 10;
  const int positions = in.next() % 14;
  const std::uint8_t flags = in.next();
  const bool with_temp = flags & 1;
  const double noise_g = (flags >> 1) % 8 == 0 ? 0.0 : 1e-6 * std::pow(4.0, (flags >> 1) % 8);
  rec.columns.temp = with_temp;
  rec.columns.mount = flags & 0x10;
  const double bias_g = (in.next() - 128) * 1e-5, scale = (in.next() - 128) * 1e-5;
  Noise noise(static_cast<std::uint32_t>(in.next()) << 8 | in.next());
  double t_s = 0;
  for (int k = 0; k < positions; ++k) {
    const double a1 = angle_deg(in.next()), a2 = angle_deg(in.next());
    const std::uint8_t shape = in.next();
    const Mount mount = rec.columns.mount ? static_cast<Mount>(shape % 3) : Mount::x;
    const int samples = 2 + (shape >> 4);
    const Vec3 up = up_vector(a1 * kDegToRad, a2 * kDegToRad, mount);
    t_s += 10;
    for (int i = 0; i < samples; ++i, t_s += 0.1) {
      RecordingSample s;
      s.t_s = t_s;
      s.pos = k;
      s.alpha1_cmd_deg = a1;
      s.alpha2_cmd_deg = a2;
      s.mount = mount;
      for (int a = 0; a < 3; ++a)
        s.f_mps2[a] = (up[a] * (1 + scale) + bias_g + noise_g * noise.next()) * rec.g_local_mps2;
      if (with_temp) s.temp_c = 20 + 0.01 * k;
      rec.samples.push_back(s);
    }
  }
  return rec;
}

void check_fit(const standcal::FitResult& fit, const char* estimator) {
  for (std::size_t j = 0; j < fit.unit.size(); ++j) {
    const auto& p = fit.unit[j];
    if (!p.value) {
      require(!p.unobservable_reason.empty(),
              std::string(estimator) + ": a parameter without value or reason");
      continue;
    }
    require(std::isfinite(*p.value), std::string(estimator) + ": a reported value is not finite");
    require(p.sigma && std::isfinite(*p.sigma) && *p.sigma >= 0,
            std::string(estimator) + ": a reported sigma is missing, not finite or negative");
  }
}

void check_diagnosis(const standcal::Diagnosis& d,
                     const std::vector<standcal::PositionAverage>& avg) {
  standcal::fuzz::check_diagnosis_output(d);
  const std::string& v = d.verdict;
  if (v != "insufficient_redundancy")
    require(standcal::distinct_orientations(avg) > standcal::kUnitParameterCount,
            "diagnosis: verdict '" + v + "' on " +
                std::to_string(standcal::distinct_orientations(avg)) +
                " distinct orientations, which cannot check nine unknowns");
}

template <class Body>
void each(const char* what, Body&& body) {
  standcal::fuzz::expect_only_runtime_errors(what, body);
}

}  // namespace

int standcal_fuzz_diagnosis(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  const standcal::Recording rec = synthetic_recording(in);
  std::vector<standcal::PositionAverage> avg;
  each("diagnosis", [&] { avg = standcal::average_positions(rec); });
  each("diagnosis", [&] { check_fit(standcal::fit_invariant_joint(avg), "joint"); });
  each("diagnosis", [&] { check_fit(standcal::fit_paper_sequential(avg), "paper-sequential"); });
  each("diagnosis", [&] { check_fit(standcal::fit_full_vector(avg), "full"); });
  each("diagnosis", [&] {
    standcal::DiagnoseOptions options;
    options.settling_tau_grid_s = {1, 4};
    check_diagnosis(standcal::diagnose_recording(rec, options), avg);
  });
  return 0;
}
