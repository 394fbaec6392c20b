#include "calib/diagnosis/residual_checks.hpp"

#include "calib/diagnosis/words.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <numeric>

namespace standcal::diagnosis {
namespace {

constexpr int kMinResidualsPerTest = 8;

// P(sup |B(t)| > x) for a Brownian bridge B (Kolmogorov's distribution).
double kolmogorov_upper_tail(double x) {
  if (x <= 0.2) return 1.0;  // the series converges slowly there; the tail is ~1 anyway
  double p = 0;
  for (int j = 1; j <= 100; ++j) {
    const double term = std::exp(-2.0 * j * j * x * x);
    p += (j % 2 == 1 ? 2.0 : -2.0) * term;
    if (term < 1e-16) break;
  }
  return std::clamp(p, 0.0, 1.0);
}

using Ordering = std::function<double(const ResidualSample&)>;

// The component's residuals sorted by the ordering variable (ties keep time order).
std::vector<const ResidualSample*> sorted_along(std::vector<const ResidualSample*> rows,
                                                const Ordering& key) {
  std::stable_sort(
      rows.begin(), rows.end(),
      [&key](const ResidualSample* a, const ResidualSample* b) { return key(*a) < key(*b); });
  return rows;
}

void span_of(WhitenessTest& t, const std::vector<const ResidualSample*>& rows, std::size_t from,
             std::size_t to) {
  t.t_from_s = 1e300;
  t.t_to_s = -1e300;
  for (std::size_t i = from; i < to; ++i) {
    t.positions.push_back(rows[i]->pos_label);
    t.t_from_s = std::min(t.t_from_s, rows[i]->t_s);
    t.t_to_s = std::max(t.t_to_s, rows[i]->t_s);
  }
}

double mean_residual(const std::vector<const ResidualSample*>& rows) {
  double sum = 0;
  for (const ResidualSample* r : rows) sum += r->r;
  return sum / static_cast<double>(rows.size());
}

// Lag-one serial correlation along the ordering (von Neumann): neighbours that agree
// mean the residuals follow a smooth pattern in that variable. It uses the residuals'
// sizes, not only their signs (a runs test needed a pattern of 5 sigma to see it on 32
// positions; this sees about 2). Upper tail only: alternating residuals are no missing
// effect. Located as the longest run of one sign.
WhitenessTest serial_test(const std::vector<const ResidualSample*>& rows) {
  WhitenessTest t;
  t.test = "serial";
  t.n = static_cast<int>(rows.size());
  const double n = static_cast<double>(rows.size());
  const double mean = mean_residual(rows);
  double ss = 0, lag = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double ri = rows[i]->r - mean;
    ss += ri * ri;
    if (i > 0) lag += ri * (rows[i - 1]->r - mean);
  }
  const double rho = ss > 0 ? lag / ss : 0.0;
  // Under white residuals rho has mean -1/n and variance (n - 2)^2 / (n^2 (n - 1)).
  t.statistic = (rho + 1 / n) / ((n - 2) / (n * std::sqrt(n - 1)));
  t.p = 0.5 * std::erfc(t.statistic / std::sqrt(2.0));
  std::size_t longest_from = 0, longest_len = 0, run_from = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (i > 0 && (rows[i]->r >= 0) != (rows[i - 1]->r >= 0)) run_from = i;
    if (i + 1 - run_from > longest_len) {
      longest_len = i + 1 - run_from;
      longest_from = run_from;
    }
  }
  span_of(t, rows, longest_from, longest_from + longest_len);
  return t;
}

// A level shift along the ordering: the largest excursion of the de-meaned cumulative
// sum, against the Brownian bridge it is for white residuals.
WhitenessTest step_test(const std::vector<const ResidualSample*>& rows) {
  WhitenessTest t;
  t.test = "step";
  t.n = static_cast<int>(rows.size());
  const double n = static_cast<double>(rows.size());
  const double mean = mean_residual(rows);
  double ss = 0;
  for (const ResidualSample* r : rows) ss += (r->r - mean) * (r->r - mean);
  const double s = std::sqrt(ss / (n - 1));
  double cum = 0, worst = 0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    cum += rows[i]->r - mean;
    if (std::abs(cum) > worst) {
      worst = std::abs(cum);
      at = i + 1;
    }
  }
  t.statistic = s > 0 ? worst / (s * std::sqrt(n)) : 0.0;
  t.p = kolmogorov_upper_tail(t.statistic);
  // Located as the positions after the step (the shorter side would do as well).
  span_of(t, rows, at, rows.size());
  return t;
}

// One residual far beyond the others: a sudden event (a jump, a knock) that a noise model
// with slow wander would otherwise absorb as a single large innovation.
WhitenessTest outlier_test(const std::vector<const ResidualSample*>& rows) {
  WhitenessTest t;
  t.test = "outlier";
  t.n = static_cast<int>(rows.size());
  std::size_t at = 0;
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (std::abs(rows[i]->r) > std::abs(rows[at]->r)) at = i;
  t.statistic = std::abs(rows[at]->r);
  // P(max of n |N(0,1)| > m) = 1 - (1 - erfc(m / sqrt 2))^n.
  t.p = -std::expm1(static_cast<double>(rows.size()) *
                    std::log1p(-std::erfc(t.statistic / std::sqrt(2.0))));
  span_of(t, rows, at, at + 1);
  return t;
}

const std::vector<std::pair<std::string, Ordering>>& orderings() {
  static const std::vector<std::pair<std::string, Ordering>> all = {
      {"time", [](const ResidualSample& r) { return r.t_s; }},
      {"alpha1", [](const ResidualSample& r) { return r.alpha1_deg; }},
      {"alpha2", [](const ResidualSample& r) { return r.alpha2_deg; }},
      {"u_x", [](const ResidualSample& r) { return r.up[0]; }},
      {"u_y", [](const ResidualSample& r) { return r.up[1]; }},
      {"u_z", [](const ResidualSample& r) { return r.up[2]; }}};
  return all;
}

void test_component(WhitenessResult& out, const std::string& component,
                    const std::vector<const ResidualSample*>& rows) {
  for (const auto& [name, key] : orderings()) {
    WhitenessTest t = serial_test(sorted_along(rows, key));
    t.component = component;
    t.against = name;
    out.tests.push_back(t);
  }
  const std::vector<const ResidualSample*> in_time = sorted_along(rows, orderings().front().second);
  for (WhitenessTest t : {step_test(in_time), outlier_test(in_time)}) {
    t.component = component;
    t.against = "time";
    out.tests.push_back(t);
  }
}

std::string output_words(const std::string& component) {
  return component == "L" ? "the invariant projection" : "the " + component + " output";
}

std::string against_words(const std::string& against) {
  if (against == "time") return "in time";
  if (against == "alpha1" || against == "alpha2") return "along the stand angle " + against;
  return "along the gravity component " + against;
}

}  // namespace

WhitenessResult whiteness_tests(const std::vector<ResidualSample>& residuals, double family_alpha) {
  WhitenessResult out;
  out.family_alpha = family_alpha;
  std::map<std::string, std::vector<const ResidualSample*>> by_component;
  for (const ResidualSample& r : residuals)
    if (std::isfinite(r.r)) by_component[r.component].push_back(&r);
  for (const auto& [component, rows] : by_component)
    if (static_cast<int>(rows.size()) >= kMinResidualsPerTest) test_component(out, component, rows);
  if (out.tests.empty()) return out;
  const double per_test = family_alpha / static_cast<double>(out.tests.size());
  for (std::size_t i = 0; i < out.tests.size(); ++i)
    if (out.worst < 0 || out.tests[i].p < out.tests[static_cast<std::size_t>(out.worst)].p)
      out.worst = static_cast<int>(i);
  out.white = out.tests[static_cast<std::size_t>(out.worst)].p >= per_test;
  return out;
}

std::string whiteness_words(const WhitenessTest& t) {
  std::string s = "the residuals of " + output_words(t.component) + " ";
  if (t.test == "serial")
    s += "follow a pattern " + against_words(t.against) +
         " (neighbours agree: serial correlation z = " + fmt("%.1f", t.statistic) +
         ", P = " + fmt("%.2g", t.p) + "); the longest run of one sign covers positions";
  else if (t.test == "outlier")
    s += "have one value of " + fmt("%.1f", t.statistic) + " sigma (P = " + fmt("%.2g", t.p) +
         " among that many), a sudden event rather than noise, at position";
  else
    s += "shift level " + against_words(t.against) +
         " (step test D*sqrt(n) = " + fmt("%.2f", t.statistic) + ", P = " + fmt("%.2g", t.p) +
         "); the shifted part covers positions";
  for (std::size_t i = 0; i < t.positions.size() && i < 12; ++i)
    s += " " + std::to_string(t.positions[i]);
  if (t.positions.size() > 12) s += " ...";
  s += " (t = " + fmt("%.0f", t.t_from_s) + " .. " + fmt("%.0f", t.t_to_s) + " s)";
  return s;
}

double half_against_whole_z(double value_half, double sigma_half, double value_all,
                            double sigma_all) {
  const double var =
      std::max(sigma_half * sigma_half - sigma_all * sigma_all, 0.1 * sigma_half * sigma_half);
  return (value_half - value_all) / std::sqrt(var);
}

void judge_half_stability(HalfStability& h, double z_limit) {
  auto z_of = [&h](double v, double s) {
    return std::isfinite(v) && std::isfinite(s) && s > 0
               ? half_against_whole_z(v, s, h.value_all, h.sigma_all)
               : 0.0;
  };
  const double z1 = z_of(h.value_first, h.sigma_first);
  const double z2 = z_of(h.value_second, h.sigma_second);
  h.z = std::abs(z1) > std::abs(z2) ? z1 : z2;
  h.stable = std::abs(h.z) <= z_limit;
}

}  // namespace standcal::diagnosis
