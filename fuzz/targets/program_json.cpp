// The programme reader (calib/programs.hpp): arbitrary JSON as a user programme, then
// normalised to a limited and a continuous stand. Properties: a programme that was read
// is written back (program_to_json) in a form that reads again with the same positions;
// its dwell and settle times are inside the run limits; a normalised angle is exactly
// equivalent (mod 360) to the one asked for, however large.
#include <cmath>
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
  const standcal::Program again =
      standcal::program_from_json(standcal::program_to_json(program), "fuzz-rewritten");
  standcal::fuzz::require(
      again.positions.size() == program.positions.size(),
      "program_json: program_to_json/program_from_json changed the number of positions");
}

void check_limits(const standcal::Program& program) {
  for (const standcal::ProgramPosition& p : program.positions) {
    standcal::fuzz::require(
        p.dwell_s.value_or(1) <= standcal::kMaxDwell_s &&
            p.settle_s.value_or(0) <= standcal::kMaxSettle_s,
        "program_json: a position's dwell or settle time past the run limits was accepted");
  }
}

bool equivalent_deg(double a_deg, double b_deg) {
  const double d =
      std::remainder(std::remainder(a_deg, 360.0) - std::remainder(b_deg, 360.0), 360.0);
  return std::abs(d) < 1e-9;
}

void check_normalised(const standcal::Program& asked, const standcal::StandLimits& limits) {
  const standcal::Program got = standcal::normalise_program(asked, limits);
  for (std::size_t i = 0; i < asked.positions.size(); ++i) {
    standcal::fuzz::require(
        equivalent_deg(got.positions[i].alpha1_deg, asked.positions[i].alpha1_deg) &&
            equivalent_deg(got.positions[i].alpha2_deg, asked.positions[i].alpha2_deg),
        "program_json: a normalised angle is not equivalent to the one asked for");
  }
}

}  // namespace

int standcal_fuzz_program_json(const std::uint8_t* data, std::size_t size) {
  const auto doc = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded())
    return 0;  // not JSON: the file loader rejects it before program_from_json
  return standcal::fuzz::expect_only_runtime_errors("program_json", [&] {
    const standcal::Program program = standcal::program_from_json(doc, "fuzz-input");
    check_round_trip(program);
    check_limits(program);
    (void)program.remount_before();
    standcal::StandLimits continuous;
    continuous.alpha1.continuous = continuous.alpha2.continuous = true;
    check_normalised(program, continuous);
    check_normalised(program, limited_stand());
  });
}
