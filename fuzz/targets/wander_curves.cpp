// The unit's static recording's Allan curves as a standcald run's header carries them
// (calib/allan.hpp parse_wander_curves; the header key kHeaderUnitStaticCurves). Properties:
// a refusal says what is wrong; curves that were read are written (wander_curves_text) to a text
// that reads again and writes to the same text, which the recording reader's check
// (wander_curves_text_error) accepts; and
// every fit of the run can weigh them: their deviance is a number at any wander size and
// correlation time the fits take.
#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>
#include <typeinfo>

#include "calib/allan.hpp"
#include "calib/recording.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

namespace {

using standcal::fuzz::require;

void check_round_trip(const standcal::WanderCurves& curves) {
  const std::string text = standcal::wander_curves_text(curves);
  require(standcal::wander_curves_text_error(text).empty(),
          "wander_curves: curves that were read, written, are refused: " +
              standcal::wander_curves_text_error(text));
  require(standcal::wander_curves_text(standcal::parse_wander_curves(text)) == text,
          "wander_curves: curves written and read again write to another text");
}

// Sizes in the curves' unit (ug) from none to far beyond any unit's, at correlation times
// across and beyond the fits' grid (60-1200 s).
void check_deviance(const standcal::WanderCurves& curves) {
  for (double q : {0.0, 1e-3, 1.0, 1e3, 1e6})
    for (double tau_s : {1.0, 60.0, 1200.0, 1e6})
      require(!std::isnan(curves.deviance(q, tau_s)),
              "wander_curves: the deviance of curves that were read is not a number at q " +
                  std::to_string(q) + ", tau " + std::to_string(tau_s) + " s");
}

}  // namespace

int standcal_fuzz_wander_curves(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = standcal::fuzz::as_text(data, size);
  standcal::WanderCurves curves;
  try {
    curves = standcal::parse_wander_curves(text);
  } catch (const standcal::fuzz::Finding&) {
    throw;
  } catch (const std::invalid_argument& e) {
    // The documented rejection, which the recording reader puts beside the key's line.
    require(*e.what() != '\0', "wander_curves: a text refused without saying what is wrong");
    return 0;
  } catch (const std::exception& e) {
    standcal::fuzz::report_finding(std::string("wander_curves: unexpected exception ") +
                                   typeid(e).name() + ": " + e.what());
  }
  check_round_trip(curves);
  check_deviance(curves);
  return 0;
}
