#pragma once
// The final fit (docs/diagnosis.md step 5): the same estimator on the averages corrected by
// the chosen terms and settling transients, its chi2/dof counting the added parameters,
// unit sigmas from the augmented fit.
#include <memory>
#include <vector>

#include "calib/diagnosis/prepare.hpp"
#include "calib/diagnosis/residual_model.hpp"
#include "calib/diagnosis/selection.hpp"
#include "calib/diagnosis/settling.hpp"

namespace standcal::diagnosis {

struct FinalFit {
  std::unique_ptr<ResidualModel> model;  // refitted on the corrected averages
  FitResult fit;                         // with the added parameters counted
  double chi2_dof = 0, p = 1;
  std::vector<TermEstimate> terms;  // of the chosen terms, in selection order
};

FinalFit final_fit(const Prepared& P, const Selection& selection,
                   const std::vector<SettlingResult>& settling);

}  // namespace standcal::diagnosis
