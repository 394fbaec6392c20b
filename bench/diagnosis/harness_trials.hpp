#pragma once
// The seeded trials of the diagnosis harness (issue 15, docs/diagnosis.md): what each
// trial conceals in a recording of the effect generator, how the diagnosis's answer is
// scored, and the ideal test's power beside a detection. bench_diagnosis_harness prints
// them; tests/diagnosis runs a fixed subset.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "bench/diagnosis/effect_generator.hpp"
#include "bench/diagnosis/ideal_test.hpp"
#include "calib/diagnosis/diagnosis.hpp"

namespace standcal::bench {

// The size a catalog term is drawn at is a multiple of its discrimination threshold: the
// diagnosis's (discrimination_thresholds on an effect-free reference recording), or, for a
// term the diagnosis does not know yet, the same definition from generator-made leftovers.
struct Threshold {
  std::string id, axis, unit;
  double tau_s = 0;  // settling_transient: the time constant it is for
  double value = 0;  // report unit
  std::string nearest;
  bool from_diagnosis = true;
  double generator_value =
      std::numeric_limits<double>::quiet_NaN();  // the generator-made one, beside it
  std::string generator_nearest;
};

// How many times its threshold a term can be before the diagnosis calls its value
// implausible (DiagnoseOptions::implausible_factor times the catalog's typical_max): the
// harness draws no size beyond it, and does not draw a term that is implausible at 3x.
double plausible_multiple(const Threshold& t);

struct HarnessSetup {
  GeneratorRun run = harness_run();
  ChamberProfile chamber;
  double run_duration_s = 0;
  std::vector<PositionAverage> reference;  // averages of the effect-free reference recording
  std::vector<TermLeftover> catalog;       // generator-made leftovers of the catalog terms
  std::vector<Threshold> thresholds;
};
// Thresholds and leftovers on an effect-free reference recording of the harness run.
HarnessSetup harness_setup();
const Threshold& threshold_of(const HarnessSetup& setup, const std::string& id,
                              const std::string& axis, double tau_s = 0);

enum class TrialKind {
  white,         // no effect, white noise: expect consistent
  coloured,      // no effect, Gauss-Markov bias on every axis: expect consistent
  catalog,       // one catalog effect, 3x-10x its threshold: expect it found (explained)
  uncatalogued,  // one effect in no catalog: expect unexplained
  pair,          // two catalog effects, 5x-10x each: expect both found (explained)
};
std::string kind_name(TrialKind kind);
// The kind of trial `index` draws: a cycle of ten with 1 white, 1 coloured, 4 catalog,
// 2 uncatalogued and 2 pairs.
TrialKind kind_of_trial(int index);

struct Drawn {
  ConcealedEffect effect;
  double threshold = 0;  // 0 for effects without one
  double expected =
      0;  // what the diagnosis should report (|amplitude|, mounting as gravity sees it)
};

struct Trial {
  int index = 0;
  TrialKind kind = TrialKind::white;
  std::uint64_t generator_seed = 0;
  GeneratorTruth truth;
  std::vector<Drawn> drawn;
};

Trial draw_trial(int index, std::uint64_t seed, const HarnessSetup& setup);
// One given catalog term, `multiple` x its threshold, random sign (angle error: phase).
Trial catalog_trial(int index, std::uint64_t seed, const HarnessSetup& setup, const Threshold& term,
                    double multiple);
// One given uncatalogued effect (bias_jump, angle_sensor_harmonic2, bias_oscillation).
Trial uncatalogued_trial(int index, std::uint64_t seed, const HarnessSetup& setup,
                         const std::string& id);

Recording record(const Trial& trial, const HarnessSetup& setup);

struct Outcome {
  std::string verdict;
  std::vector<Finding>
      findings;  // deterministic findings (not noise findings), most significant first
  std::vector<std::string> summary;
  bool right = false;
  bool false_finding = false;  // effect-free: a deterministic finding, or an ambiguous pair named
  int found = 0;               // drawn catalog effects among the findings (anywhere)
  int within_3sigma = 0;       // of those, values within 3 sigma of the truth
  bool right_unspecified = false;  // coloured: right also without the unit's specified wander
};
// Coloured-noise trials are diagnosed with the unit's specified wander (kSpecifiedWander,
// what a data sheet or `standcal noise` on a static recording gives: the same bound for
// every such unit, not the drawn truth) unless `without_specification`.
Outcome diagnose_trial(const Trial& trial, const Recording& rec,
                       bool without_specification = false);
// The specification the coloured-noise units come with: Gauss-Markov up to 5 ug, 300 s.
GaussMarkovNoise specified_wander();
// Whether the findings name the effect with its axis.
bool finds(const Outcome& outcome, const ConcealedEffect& effect);

// One trial of the power table: the diagnosis's detection and the ideal test's power.
struct PowerPoint {
  bool detected = false;
  double ideal_power = 0;
};
PowerPoint power_trial(const Trial& trial, const HarnessSetup& setup);

}  // namespace standcal::bench
