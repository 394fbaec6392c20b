#pragma once
// The catalog of physics the calibration model leaves out (model.md, "Physics the model
// leaves out"), as data: one row per effect id with its axes, parametrisation, report unit,
// contribution to J, words, visibility and plausible size. Adding an effect to the
// diagnosis means adding one row to the table in catalog.cpp (and its column function).
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "calib/diagnosis/position_context.hpp"

namespace standcal::diagnosis {

// What an entry's `axis` names.
enum class CatalogAxes {
  output,       // one accelerometer output: "x", "y", "z"
  output_pair,  // an ordered pair of outputs, the output first: "zx" is K_zx a_z a_x on z
  stand_axis,   // a stand axis: "alpha1" (outer), "alpha2" (inner)
  level_axis,   // an axis of the stand's levelling error: "x" (x_S) or "z" (z_S)
};

// How the diagnosis tests an entry.
enum class CatalogTest {
  columns,        // extra columns of the linearised baseline, chosen by term selection
  raw_samples,    // a search on the raw samples inside each dwell (settling.hpp)
  baseline_size,  // the size of a baseline parameter against a tolerance (mounting.hpp)
};

// How a term's parameters are reported.
enum class Parametrisation {
  coefficient,  // one coefficient per axis
  cyclic,       // a sin(alpha) + b cos(alpha), reported as amplitude and phase (2 parameters)
};

struct Candidate;
// A column term's contribution to J (g) per report unit of each of its parameters at one
// position: 3 x params.
using EffectColumns = Eigen::MatrixXd (*)(const Candidate&, const PositionContext&);
// Words about an entry on one axis.
using AxisWords = std::string (*)(const std::string& axis);

struct CatalogEntry {
  const char* id;  // stable: it appears in machine-readable output
  CatalogAxes axes;
  CatalogTest test;
  Parametrisation parametrisation;
  const char* unit;  // report unit
  bool needs_temperature;
  // Seen by the invariant projection u^T J - 1 to first order; terms that only turn the
  // measured vector (uT du = 0) are not.
  bool invariant_visible;
  // The largest physically plausible size (report unit) for the navigation-grade unit and
  // the good stand of model.md's "typical magnitudes".
  double typical_max;
  // What must vary on a programme for the term to show ("too little <excitation> on this
  // programme"), for the reason a candidate is not testable.
  const char* excitation;
  EffectColumns effect_g;     // test == columns only
  AxisWords effect_words;     // the physics: "bias drift of the x accelerometer"
  AxisWords signature_words;  // what its residuals do: "grow with time since the start"

  int params() const { return parametrisation == Parametrisation::cyclic ? 2 : 1; }
};

// Every entry, in the order candidates are listed.
const std::vector<CatalogEntry>& catalog();
// The entry of an id, or null for an id the catalog does not have.
const CatalogEntry* find_catalog_entry(const std::string& id);
// The entry of an id; throws std::out_of_range for an id the catalog does not have.
const CatalogEntry& catalog_entry(const std::string& id);

// One catalog entry on one axis: a candidate term of the selection.
struct Candidate {
  const CatalogEntry* entry = nullptr;
  std::string axis;
  int out_axis = 0;     // output axis (output, output_pair), 0 / 2 for level_axis x / z
  int other_axis = -1;  // output_pair only

  std::string effect() const { return entry->id; }
  std::string unit() const { return entry->unit; }
  int params() const { return entry->params(); }
};

// The column candidates on every axis: per output axis its terms and its ordered pairs,
// then the stand-side terms (stand axes, levelling axes). Temperature terms only when the
// recording has a temperature.
std::vector<Candidate> catalog_candidates(bool have_temperature);

// The candidate's contribution to J (g) per report unit: 3 x params.
Eigen::MatrixXd candidate_effect_g(const Candidate& c, const PositionContext& p);

// The catalog's words for an id on an axis (the id itself / "show structure" when unknown).
std::string effect_words(const std::string& id, const std::string& axis);
std::string signature_words(const std::string& id, const std::string& axis);

}  // namespace standcal::diagnosis
