// A fixed seeded subset of the diagnosis harness (issue 15; bench_diagnosis_harness draws
// the same trials at random): recordings of the independent effect generator, scored by the
// harness's rules. Cases the diagnosis cannot pass yet are written and DISABLED_, each
// naming the part of issue 15 it waits for; enable them as those parts land.
#include <gtest/gtest.h>

#include <cstdio>

#include <nlohmann/json.hpp>

#include "bench/diagnosis/harness_trials.hpp"
#include "calib/recording.hpp"
#include "protocol/jsonrpc/exit_codes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::bench {
namespace {

constexpr std::uint64_t kSeed = 15;

const HarnessSetup& setup() {
  static const HarnessSetup s = harness_setup();
  return s;
}

std::string said(const Outcome& o) {
  std::string s = "verdict " + o.verdict;
  for (const Finding& f : o.findings)
    s += "; " + f.effect + " " + f.axis + " " + std::to_string(f.value) + " +- " +
         std::to_string(f.sigma);
  for (const std::string& line : o.summary) s += "\n  " + line;
  return s;
}

// The harness's rule for the trial's kind, and every found value within 3 sigma.
void expect_right(const Trial& t) {
  const Outcome o = diagnose_trial(t, record(t, setup()));
  std::string drawn;
  for (const Drawn& d : t.drawn)
    drawn += d.effect.id + " " + d.effect.axis + " " + std::to_string(d.effect.value) + "; ";
  EXPECT_TRUE(o.right) << kind_name(t.kind) << " trial " << t.index << ": " << drawn << "\n"
                       << said(o);
  EXPECT_EQ(o.within_3sigma, o.found) << drawn << "\n" << said(o);
}

void expect_catalog_term_found(const std::string& id, const std::string& axis, double tau_s,
                               int index) {
  SCOPED_TRACE(id + " " + axis);
  expect_right(catalog_trial(index, kSeed, setup(), threshold_of(setup(), id, axis, tau_s), 5));
}

// Trials of draw_trial whose index gives `kind` (the harness's cycle of ten).
void expect_drawn_right(TrialKind kind, int count) {
  for (int index = 0, done = 0; done < count; ++index)
    if (kind_of_trial(index) == kind) {
      expect_right(draw_trial(index, kSeed, setup()));
      ++done;
    }
}

// Both codes compute model.md's discrimination threshold on the same programme: the
// diagnosis from its own linearised columns, the harness from generator-made recordings
// through fit_full_vector. Where they name the same nearest competitor they must agree.
TEST(HarnessSubset, GeneratorMadeThresholdsAgreeWithTheDiagnosis) {
  int compared = 0;
  for (const Threshold& t : setup().thresholds) {
    if (!t.from_diagnosis || t.nearest != t.generator_nearest) continue;
    EXPECT_NEAR(t.generator_value, t.value, 0.01 * t.value) << t.id << " " << t.axis;
    ++compared;
  }
  EXPECT_GE(compared, 15);
}

// An uncatalogued effect must not be a combination of catalog terms in disguise: at least a
// tenth of its per-position pattern stays unexplained by all of them together.
TEST(HarnessSubset, UncataloguedEffectsAreNoCombinationOfCatalogTerms) {
  for (const char* id : {"bias_jump", "angle_sensor_harmonic2", "bias_oscillation"})
    for (int i = 0; i < 5; ++i) {
      const Trial t = uncatalogued_trial(900 + i, kSeed, setup(), id);
      const Eigen::VectorXd r =
          baseline_leftover(t.truth.effects, setup().chamber, setup().run, setup().reference);
      EXPECT_GT(unexplained_norm(r, setup().catalog) / r.norm(), 0.1) << id << " draw " << i;
    }
}

// Every id a plausible size can show at 5x its threshold (not K3 and K_oq on diagnostic32).
TEST(HarnessSubset, CatalogEffectsAreFoundWithTheirAxisAndValue) {
  expect_catalog_term_found("scale_nonlinearity_k2", "z", 0, 1);
  expect_catalog_term_found("cross_coupling", "xy", 0, 3);
  expect_catalog_term_found("bias_temperature", "y", 0, 4);
  expect_catalog_term_found("scale_temperature", "z", 0, 5);
  expect_catalog_term_found("bias_drift", "x", 0, 6);
  expect_catalog_term_found("hysteresis", "y", 0, 7);
  expect_catalog_term_found("settling_transient", "z", 4, 8);
  expect_catalog_term_found("mounting_misalignment_large", "y", 0, 9);
  expect_catalog_term_found("angle_sensor_error", "alpha1", 0, 10);
}

TEST(HarnessSubset, WhiteNoiseWithoutEffectIsConsistent) {
  expect_drawn_right(TrialKind::white, 3);
}

// With the unit's specified wander (harness_trials.hpp): one 6-minute run cannot tell 2-5 ug
// of Gauss-Markov wander from a drift or a temperature coefficient by itself.
TEST(HarnessSubset, ColouredNoiseWithoutEffectIsConsistent) {
  expect_drawn_right(TrialKind::coloured, 3);
}

// `standcal diagnose --bias-instability-ug`: a coloured recording that comes out with a
// finding when the unit's wander is unknown is `consistent` once the operator gives it.
TEST(HarnessSubset, TheCliTakesTheUnitsSpecifiedWander) {
  const Trial* wrong_without = nullptr;
  std::vector<Trial> coloured;
  for (int index = 0; coloured.size() < 10; ++index)
    if (kind_of_trial(index) == TrialKind::coloured)
      coloured.push_back(draw_trial(index, kSeed, setup()));
  for (const Trial& t : coloured)
    if (!wrong_without && !diagnose_trial(t, record(t, setup()), true).right) wrong_without = &t;
  ASSERT_NE(wrong_without, nullptr) << "no coloured draw needs the specification";
  test::TempDir dir;
  const std::string path = dir.file("coloured.csv");
  write_recording(record(*wrong_without, setup()), path);
  auto verdict = [&](const std::string& extra) {
    const test::CommandOutcome r =
        test::standcal_cli("diagnose --json " + path + extra + " 2>/dev/null");
    const nlohmann::json j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
    EXPECT_EQ(r.exit_code, exit_status(diagnosis_exit_code(j.value("verdict", "")))) << r.output;
    return j;
  };
  EXPECT_NE(verdict("")["verdict"], "consistent");
  const nlohmann::json with = verdict(" --bias-instability-ug 5 --bias-instability-tau-s 300");
  EXPECT_EQ(with["verdict"], "consistent") << with["summary"].dump(1);
  EXPECT_EQ(with["noise"]["source"], "specified");
}

TEST(HarnessSubset, UncataloguedEffectsAreUnexplained) {
  for (const char* id : {"bias_jump", "angle_sensor_harmonic2", "bias_oscillation"})
    for (int i = 0; i < 2; ++i) expect_right(uncatalogued_trial(20 + i, kSeed, setup(), id));
}

// K_oq and K3 cannot be told apart on diagnostic32 below an implausible size (their
// thresholds are 93-1300 against 10 x 20 ug/g2): the harness does not draw them.
TEST(HarnessSubset, ScaleAsymmetryAndK3AreNotDrawnAtImplausibleSizes) {
  for (const char* axis : {"x", "y", "z"}) {
    EXPECT_LT(plausible_multiple(threshold_of(setup(), "scale_asymmetry", axis, 0)), 3) << axis;
    EXPECT_LT(plausible_multiple(threshold_of(setup(), "scale_nonlinearity_k3", axis, 0)), 3)
        << axis;
  }
  EXPECT_GE(plausible_multiple(threshold_of(setup(), "scale_nonlinearity_k2", "z", 0)), 3);
}

TEST(HarnessSubset, StandLevelDriftIsFound) {
  expect_catalog_term_found("stand_level_drift", "z", 0, 12);
}

TEST(HarnessSubset, PairsAreFoundTogether) { expect_drawn_right(TrialKind::pair, 4); }

}  // namespace
}  // namespace standcal::bench
