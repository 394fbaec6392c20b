#pragma once
// Everything the diagnosis derives from a recording before it tests candidates: position
// averages and contexts, the residual model with its baseline fit, and which catalog
// candidates this programme can test at all.
#include <memory>
#include <string>
#include <vector>

#include "calib/diagnosis/catalog.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/diagnosis/position_context.hpp"
#include "calib/diagnosis/residual_model.hpp"
#include "calib/diagnosis/selection.hpp"

namespace standcal::diagnosis {

struct Prepared {
  std::vector<PositionAverage> avg;
  std::optional<AllanFinding> allan;  // the dwells' pooled Allan curves' figures (averaging)
  bool have_temp = true;
  double temp_ref_c = 0;
  std::vector<PositionContext> ctx;
  std::unique_ptr<ResidualModel> model;
  LinearFit base;  // the linearised baseline, no candidate
  std::vector<Candidate> cands;
  std::vector<std::string> untestable;  // per candidate: why it cannot be tested, or empty
  std::vector<bool> implausible;        // untestable only because no plausible size would show
  // Candidates whose signature the calibration parameters do not absorb (testable, or
  // testable but for their plausible size): what the programme's positions can separate.
  int n_standing_out = 0;
};

// Throws CannotFit for a recording that cannot be checked (no position, numbers that are
// not finite, a dwell whose samples do not vary, not even the calibration fits).
Prepared prepare(const Recording& rec, const DiagnoseOptions& options);

}  // namespace standcal::diagnosis
