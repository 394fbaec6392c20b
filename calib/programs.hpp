#pragma once
// Calibration programmes: the paper's 9 positions (Table 2), the classic 24, and user
// programmes from JSON; validated and normalised against the stand's axis ranges.
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/axis_range.hpp"
#include "calib/model.hpp"

namespace standcal {

// A run's limits on a position's dwell and settle time (docs/protocol.md, run.start): a
// position may not ask for more than a whole run may.
inline constexpr double kMaxDwell_s = 36000;
inline constexpr double kMaxSettle_s = 3600;

struct ProgramPosition {
  double alpha1_deg = 0;
  double alpha2_deg = 0;
  Mount mount = Mount::x;
  std::optional<double> dwell_s;   // overrides the run's dwell
  std::optional<double> settle_s;  // overrides the run's settle time
};

struct Program {
  std::string name;
  std::vector<ProgramPosition> positions;
  // The first position held this long before its dwell, the unit recorded (a warm-up: it
  // settles, and its samples show the noise model its wander, while its mean is the dwell's
  // alone: Recording::warmup_s). 0: none.
  double warmup_s = 0;

  // Indices of positions that need an operator re-mount first (mount differs from the
  // previous position's). The first position's mount is the one the run starts with.
  std::vector<std::size_t> remount_before() const;
};

struct StandLimits {
  AxisRange alpha1;
  AxisRange alpha2;
};

// A programme that cannot be used; the message names the source and the position.
class ProgramError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The paper's Table 2: five alpha1 steps of 72 deg from alpha1_start at alpha2 = 0,
// alpha2 = 57.5/122.5/270 deg at alpha1 = 0, and (45 + n*90, 90).
Program paper9(double alpha1_start_deg = 0, int position9_n = 0);
// Three mountings x, y, z; alpha1 = 90, 270 x alpha2 = 0, 90, 180, 270 (model.md).
Program classic24();
// A user programme from JSON {"name": ..., "positions": [{"alpha1_deg", "alpha2_deg",
// "mount"?, "dwell_s"?, "settle_s"?}, ...]}; `source` names it in errors. Unknown keys,
// a name that is not one line of printable text, and a dwell or settle time past the
// run limits (kMaxDwell_s, kMaxSettle_s) are errors.
Program program_from_json(const nlohmann::json& doc, const std::string& source);
// "paper9", "classic24", or a path to a JSON programme file.
Program load_program(const std::string& name_or_path, double paper9_alpha1_start_deg = 0);
// The programme as JSON (the schema program_from_json reads).
nlohmann::json program_to_json(const Program& program);

// Where a programme puts a position on one axis (equivalent_angle_deg's rule): continuous
// axes give [-180, 180); limited axes keep the angle if inside, else take the equivalent
// nearest the middle of the range (the stand's cable_wrap then picks the turn it moves
// to). Empty when no equivalent angle lies inside. Exact for every finite angle (1e308
// gives -64).
std::optional<double> normalise_angle_deg(double angle_deg, const AxisRange& range);

// Angles of one stand axis every step_deg across its range: from the range's start (-180 deg
// on a continuous axis) and, on a limited axis, its end. The candidate grid of programme
// design (calib/design) and of the diagnosis's proposed positions.
std::vector<double> axis_grid_deg(const AxisRange& range, double step_deg);
// Every position normalised to the stand's ranges; throws ProgramError naming the first
// position and axis that cannot be reached.
Program normalise_program(const Program& program, const StandLimits& limits);

}  // namespace standcal
