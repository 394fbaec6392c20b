#include "bench/budget/budget_coverage.hpp"

#include <cmath>
#include <random>
#include <thread>

#include "calib/full_estimator.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/model.hpp"
#include "calib/simulator.hpp"

namespace standcal::budget_mc {

namespace {

struct Draw {
  StandErrors stand;
  double g_true_mps2 = 0;
  Vec3 bias_tc_g_per_c = Vec3::Zero();
  Vec3 scale_tc_per_c = Vec3::Zero();
};

Draw draw(const Setup& s, std::mt19937_64& rng) {
  const auto uniform = [&rng](double bound) {
    return std::isnan(bound) ? 0.0 : std::uniform_real_distribution<double>(-bound, bound)(rng);
  };
  const BudgetConfig& c = s.draw_from ? *s.draw_from : s.config;
  Draw d;
  d.stand.alpha1_offset_rad = uniform(c.angle_zero_arcsec) * kArcsecToRad;
  d.stand.alpha2_offset_rad = uniform(c.angle_zero_arcsec) * kArcsecToRad;
  d.stand.skew_y_rad = uniform(c.orthogonality_arcsec) * kArcsecToRad;
  d.stand.skew_z_rad = uniform(c.orthogonality_arcsec) * kArcsecToRad;
  d.stand.levelling_x_rad = uniform(c.level_arcsec) * kArcsecToRad;
  d.stand.levelling_z_rad = uniform(c.level_arcsec) * kArcsecToRad;
  Vec3 mounting;
  for (int a = 0; a < 3; ++a) mounting[a] = uniform(c.mounting_arcsec) * kArcsecToRad;
  for (Vec3& m : d.stand.mounting_rad) m = mounting;  // one fixture
  const double u_g =
      std::isnan(c.g_standard_uncertainty_mps2) ? 0.0 : c.g_standard_uncertainty_mps2;
  d.g_true_mps2 = s.g_used_mps2 + std::normal_distribution<double>(0, 1)(rng) * u_g;
  const auto type = c.unit_types.find(s.unit_type);
  if (type != c.unit_types.end()) {
    for (int a = 0; a < 3; ++a) {
      d.bias_tc_g_per_c[a] = uniform(type->second.bias_ug_per_c) * kUg;
      d.scale_tc_per_c[a] = uniform(type->second.scale_ppm_per_c) * kPpm;
    }
  }
  return d;
}

// The dwell means the stand would give, from the forward model, with white noise.
std::vector<PositionAverage> measure(const Setup& s, const UnitErrors& unit, const Draw& d,
                                     std::mt19937_64& rng) {
  const std::size_t n = s.program.positions.size();
  const double sigma = s.mean_error_ug * kUg;
  std::normal_distribution<double> noise(0, sigma);
  std::vector<PositionAverage> out;
  const double t_ref = (s.temperature_start_c + s.temperature_end_c) / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const ProgramPosition& p = s.program.positions[i];
    PositionAverage a;
    a.pos = static_cast<int>(i);
    a.alpha1_cmd_deg = p.alpha1_deg;
    a.alpha2_cmd_deg = p.alpha2_deg;
    a.mount = p.mount;
    a.temp_mean_c = s.temperature_start_c + (s.temperature_end_c - s.temperature_start_c) *
                                                static_cast<double>(i) / static_cast<double>(n - 1);
    UnitErrors at_t = unit;
    at_t.bias_g += d.bias_tc_g_per_c * (a.temp_mean_c - t_ref);
    at_t.scale += d.scale_tc_per_c * (a.temp_mean_c - t_ref);
    const Vec3 j = unit_output_g(
        at_t, true_up_vector(p.alpha1_deg * kDegToRad, p.alpha2_deg * kDegToRad, p.mount, d.stand));
    // The unit measures g_true J; the recording divides by the g the lab used.
    a.mean_g = j * d.g_true_mps2 / s.g_used_mps2 + Vec3(noise(rng), noise(rng), noise(rng));
    a.standard_error_g = Vec3::Constant(sigma);
    a.samples = 1000;
    a.sigma_g = Vec3::Constant(sigma * std::sqrt(1000.0));
    a.t_start_s = 60.0 * static_cast<double>(i);
    a.t_end_s = a.t_start_s + 30;
    a.t_arrive_s = a.t_start_s;
    out.push_back(a);
  }
  return out;
}

Eigen::Matrix<double, 9, 1> truth_vector(const UnitErrors& unit) {
  Eigen::Matrix<double, 9, 1> t;
  t << unit.bias_g, unit.scale, unit.gamma_pair_sums_rad();
  return t;
}

}  // namespace

BudgetConfig data_sheet_config() {
  BudgetConfig c;
  c.source = "bench data sheet";
  c.stand_source = "two-axis stand data sheet (bench values)";
  c.angle_zero_arcsec = 10;
  c.orthogonality_arcsec = 10;
  c.level_arcsec = 20;
  c.mounting_arcsec = 120;
  c.g_standard_uncertainty_mps2 = 2e-5;
  c.g_source = "gravity survey (bench value)";
  c.unit_types["QA-2000"] = {1.0, 0.5};
  return c;
}

namespace {

// Sums over the runs [first, last): merged across threads, divided at the end.
struct Sums {
  std::array<double, kUnitParameterCount> covered{}, z2{}, type_b_share{}, k{};
  std::array<int, kUnitParameterCount> counted{};
  int runs = 0;
  int failed = 0;
};

void run_range(const Setup& s, int first, int last, Sums& sums) {
  const UnitErrors unit = default_truth().unit;
  const Eigen::Matrix<double, 9, 1> truth = truth_vector(unit);
  for (int r = first; r < last; ++r) {
    std::mt19937_64 rng(s.first_seed + static_cast<std::uint64_t>(r));
    const Draw d = draw(s, rng);
    const std::vector<PositionAverage> averages = measure(s, unit, d, rng);
    try {
      const FitResult fit =
          s.estimator == "full" ? fit_full_vector(averages) : fit_invariant_joint(averages);
      const UncertaintyBudget b = evaluate_budget(averages, fit, budget_estimator(s.estimator, fit),
                                                  s.config, s.unit_type, s.g_used_mps2);
      for (std::size_t i = 0; i < kUnitParameterCount; ++i) {
        if (!fit.unit[i].value) continue;
        const ParameterBudget& pb = b.parameters[i];
        const double error = *fit.unit[i].value - truth[static_cast<Eigen::Index>(i)];
        sums.covered[i] += std::abs(error) <= pb.expanded ? 1 : 0;
        sums.z2[i] += std::pow(error / pb.combined, 2);
        sums.type_b_share[i] += 1 - std::pow(pb.type_a / pb.combined, 2);
        sums.k[i] += pb.coverage_factor;
        ++sums.counted[i];
      }
      ++sums.runs;
    } catch (const std::exception&) {
      ++sums.failed;
    }
  }
}

}  // namespace

Coverage run_coverage(const Setup& s) {
  const int threads = std::max(1, s.threads);
  std::vector<Sums> parts(static_cast<std::size_t>(threads));
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back(run_range, std::cref(s), s.runs * t / threads, s.runs * (t + 1) / threads,
                         std::ref(parts[static_cast<std::size_t>(t)]));
  }
  for (std::thread& w : workers) w.join();
  Coverage c;
  for (std::size_t i = 0; i < kUnitParameterCount; ++i) {
    double n = 0;
    for (const Sums& p : parts) {
      c.covered[i] += p.covered[i];
      c.z2[i] += p.z2[i];
      c.type_b_share[i] += p.type_b_share[i];
      c.mean_k[i] += p.k[i];
      n += p.counted[i];
    }
    n = std::max(n, 1.0);
    c.covered[i] /= n;
    c.z2[i] /= n;
    c.type_b_share[i] /= n;
    c.mean_k[i] /= n;
  }
  for (const Sums& p : parts) {
    c.runs += p.runs;
    c.failed += p.failed;
  }
  return c;
}

}  // namespace standcal::budget_mc
