// The programme reader (calib/programs.hpp): arbitrary JSON as a user programme, then
// normalised to a limited and a continuous stand. Property: a programme that was read
// is written back (program_to_json) in a form that reads again with the same positions.
#include <nlohmann/json.hpp>
#include <string>

#include "calib/programs.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace {

standcal::StandLimits limited_stand() {
  standcal::StandLimits limits;
  limits.alpha1 = {false, -170, 190};
  limits.alpha2 = {false, -90, 90};
  return limits;
}

void check_round_trip(const standcal::Program& program) {
  const standcal::Program again = standcal::program_from_json(standcal::program_to_json(program), "fuzz-rewritten");
  standcal::fuzz::require(again.positions.size() == program.positions.size(),
                          "program_json: program_to_json/program_from_json changed the number of positions");
}

}  // namespace

int standcal_fuzz_program_json(const std::uint8_t* data, std::size_t size) {
  const auto doc = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: the file loader rejects it before program_from_json
  return standcal::fuzz::expect_only_runtime_errors("program_json", [&] {
    const standcal::Program program = standcal::program_from_json(doc, "fuzz-input");
    check_round_trip(program);
    (void)program.remount_before();
    standcal::StandLimits continuous;
    continuous.alpha1.continuous = continuous.alpha2.continuous = true;
    (void)standcal::normalise_program(program, continuous);
    (void)standcal::normalise_program(program, limited_stand());
  });
}
