#pragma once
// What every diagnosis must be, whatever recording it came from (a stand's or one without
// angles): one of the five verdicts, finite findings, and JSON that serialises.
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "calib/diagnosis/diagnosis.hpp"
#include "calib/json_text.hpp"
#include "fuzz/targets/fuzz_support.hpp"

namespace standcal::fuzz {

inline void check_diagnosis_output(const Diagnosis& d) {
  const std::string& v = d.verdict;
  require(v == "consistent" || v == "explained" || v == "unexplained" ||
              v == "insufficient_redundancy" || v == "ambiguous",
          "diagnosis: unknown verdict '" + v + "'");
  for (const auto& f : d.findings)
    require(std::isfinite(f.value) && std::isfinite(f.sigma),
            "diagnosis: finding " + f.effect + " is not finite");
  (void)json_text(diagnose_to_json(d));  // as `diagnose --json` prints it
}

}  // namespace standcal::fuzz
