#pragma once
// Which noise the terms are tested against (docs/diagnosis.md, "Noise"): white, or the
// bias wander of model.md's bias_instability when the recording shows it. The two compete
// with the deterministic terms for the same slow residuals (a drift is wander that happens
// to be straight), so the wander is estimated with every slow catalog term in the model and
// the terms are then selected under it.
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/selection.hpp"
#include "calib/noise_model.hpp"

namespace standcal::diagnosis {

struct NoiseAndTerms {
  NoiseEstimate noise;
  Selection selection;
  // The run shows a wander that agrees with the unit's given one (size and correlation
  // time), which the terms are then tested against, as the fits weigh with it.
  bool weighted_as_specified = false;
  // The floor under the correlation time (KnownTau::open_above) was set aside: these rows do
  // not show the wander under it; the wander was estimated without it.
  bool tau_floor_set_aside = false;
};

// `options` with the unit's wander where nothing of it is given, by the rule of the fits for a
// pinned wander (take_unit_wander; the diagnosis weighs no bound on one): the one `rec`'s header
// says its run was made with, else the one its own long dwell pins (its dwells' pooled Allan
// curves, `allan`; for a recording without angles, of its static intervals, as its norm fit takes
// it), else the higher floor under its correlation time that the unit's static recording
// (options.unit_static_tau_floor_s, else the one the header carries) and that long dwell put.
DiagnoseOptions with_unit_wander(DiagnoseOptions options, const Recording& rec,
                                 const std::optional<AllanFinding>& allan);

// Sets P.model's noise and P.base to the final choice.
NoiseAndTerms select_terms_and_noise(Prepared& P, const DiagnoseOptions& options);

// A sentence for the summary: empty for white noise.
std::string noise_words(const NoiseFinding& n);

}  // namespace standcal::diagnosis
