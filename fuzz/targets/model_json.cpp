// The model file reader (calib/simulator.hpp truth_from_json, format standcal-model/1).
// Property: a model that was read is written back (truth_to_json) in a form that reads again.
#include <nlohmann/json.hpp>

#include "calib/simulator.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

int standcal_fuzz_model_json(const std::uint8_t* data, std::size_t size) {
  const auto doc = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: load_truth rejects it before truth_from_json
  return standcal::fuzz::expect_only_runtime_errors("model_json", [&] {
    const standcal::TruthModel truth = standcal::truth_from_json(doc, "fuzz-input");
    try {
      (void)standcal::truth_from_json(standcal::truth_to_json(truth), "fuzz-rewritten");
    } catch (const std::runtime_error& e) {
      standcal::fuzz::report_finding(
          std::string("model_json: a model that was read cannot be read back after "
                      "writing it: ") +
          e.what());
    }
  });
}
