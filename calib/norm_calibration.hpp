#pragma once
// Calibration of a recording no stand angle describes (`standcal fit FILE --method norm`):
// static intervals (detected, the recording's dwell blocks, or a table of means), the
// attitude-free fit, and how far its result moves when the detector's threshold is halved
// or doubled. Serialised to the JSON of `fit --json` and to the text report.
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/allan.hpp"
#include "calib/norm_estimator.hpp"
#include "calib/raw_input.hpp"
#include "calib/static_intervals.hpp"

namespace standcal {

inline constexpr std::array<std::string_view, 9> kNormParameterNames{
    "bias_x", "bias_y", "bias_z", "scale_x", "scale_y", "scale_z", "m01", "m02", "m12"};

struct NormCalibrationOptions {
  StaticDetectorOptions detector;
  NormFitOptions fit;
  bool stability = true;  // refit at half and twice the detector's threshold
  // A long static recording of the same unit apart from this one, in the same input units
  // (`standcal fit --unit-static-recording FILE`), its static stretches found by `detector`.
  // Where nothing of the unit's wander is given, the wander its Allan curves pin is taken as
  // the unit's (take_recording_wander), and where they show none, they bound the wander the
  // sigmas allow for (take_wander_curves); either before this recording's own long intervals.
  // Where they see one they do not pin, the floor they put under its correlation time, where it
  // is higher than this recording's own (take_higher_tau_floor).
  // Its curves are put in ug by this fit's compensation, so counts need no scale of their own.
  std::shared_ptr<const RawInput> unit_static_recording;
};

// What the unit's static recording (NormCalibrationOptions::unit_static_recording) gave the
// fit, for its JSON and report.
struct UnitStaticRecordingUse {
  std::string source;
  double static_s = 0;      // the static time its curves pool
  double curves_end_s = 0;  // their longest averaging time
  // "wander" (the one its curves pin, weighted with), "bound" (curves that show none weighed
  // the wander the sigmas allow for), "floor" (curves that see a wander they do not pin put
  // its correlation time at tau_floor_s or longer, and the fit kept that floor; standcald's:
  // given to its runs, each of whose fits settles it), "curves"
  // (standcald's: curves that show none, which each run's header carries to bound its
  // wander: take_static_recording_for_runs) or "nothing".
  std::string gave = "nothing";
  std::string why;     // in words: what its curves show, and why that gave what it gave
  GivenWander wander;  // "wander": the one it gave (its size and correlation times)
  std::vector<std::string> warnings;  // its reader's, each naming the file
  // The stand recording's own long dwell put a floor under the correlation time beside it
  // (take_recording_tau_floor): settle_unit_static_use says so, and whether the fit kept it.
  bool recording_tau_floor = false;
  double tau_floor_s = 0;  // "floor": the shortest correlation time its curves allow
};

// A static recording of the unit, its curves in ug (`ug_per_unit`: per input unit) fitted once:
// the wander they pin and, where they show none, the curves as a bound on one
// (AllanFinding::wander, wander_curves), with what they show in use.why. Its static stretches
// are found by `detector` with one orientation allowed. Throws std::runtime_error naming the
// file: a table of means, no static interval.
struct UnitStaticAllan {
  AllanFinding allan;
  UnitStaticRecordingUse use;
  // The fit of white noise and one wander to its curves (ug), where they are long enough: its
  // white_density is the white noise beside the wander, which the curves' -1/2 slope read at
  // 1 s (allan.figures) overstates where a wander of seconds to minutes is there.
  std::optional<GaussMarkovAllanFit> gauss_markov;
};
UnitStaticAllan unit_static_allan(const RawInput& recording, const Vec3& ug_per_unit,
                                  const StaticDetectorOptions& detector = {});
// The same for a stand fit or diagnosis: its curves in ug (g, or m/s^2 over the stand
// recording's g). A recording in counts is refused: it has no scale without the norm fit's
// compensation.
UnitStaticAllan stand_unit_static_allan(const RawInput& recording, double g_mps2);
// The wander its curves pin, as the unit's where nothing of it is given (take_recording_wander,
// kWanderFromStaticRecording), and nothing else: for a caller that weighs no curves (design,
// the diagnosis) or takes them after other wanders (the fits). Returns what it gave and why.
UnitStaticRecordingUse take_static_recording_pinned_wander(FitNoiseOptions& options,
                                                           const UnitStaticAllan& unit_static);
// standcald's use of the unit's static recording for its runs (`options`: nothing of the
// unit's wander given): the wander its curves pin (take_static_recording_pinned_wander), else,
// where they show none and reach the fits' shortest correlation time, the curves themselves
// (`options.wander_curves_ug`), which each run's header carries (kHeaderUnitStaticCurves) and
// each fit of the run weighs as a bound (gave "curves"), else, where they see a wander they do
// not pin, the floor they put under its correlation time (`options.known_tau`), which each
// run's header carries (kHeaderUnitStaticTauFloorS; gave "floor", before any fit), else why
// none.
UnitStaticRecordingUse take_static_recording_for_runs(FitNoiseOptions& options,
                                                      const UnitStaticAllan& unit_static);
// Where its curves show no wander: them as a bound on the wander the sigmas allow for, where no
// size of the unit's is given (take_wander_curves); `use` then says "bound" until the fit
// settles it (settle_unit_static_use), or why not.
void take_static_recording_bound(FitNoiseOptions& options, const UnitStaticAllan& unit_static,
                                 UnitStaticRecordingUse& use);
// The stand fits' unit wander where nothing of it is given (`standcal fit
// --unit-static-recording` with a stand method, import, certificate), in their order: the one
// the recording's header gives (what its run was made with), else the one the unit's static
// recording pins (`unit_static`, null where none was given), else the one the recording's own
// long dwell pins (`allan`); where none is pinned and no size of the unit's is given, the
// static recording's curves that show none bound the wander the sigmas allow for (without
// `unit_static`, the ones the header carries from its run: take_header_static_curves), and
// the higher floor under the correlation time that either's curves put (take_higher_tau_floor;
// beside the static recording's, the long dwell's bound), else the long dwell's bound
// (take_wander_curves, take_recording_wander_or_bound), as the norm fit takes them: a stand fit
// that weighs for a wander below the bar of a finding then has its sigmas averaged over the sizes
// this run and the curves allow, not widened by Student-t at the few degrees of freedom the run
// leaves the wander's size. Returns what the static recording gave and why, where one was given: a
// bound taken is settled by the fit (settle_unit_static_use).
std::optional<UnitStaticRecordingUse> take_unit_wander_with_static_recording(
    FitNoiseOptions& options, const Recording& rec, const std::optional<AllanFinding>& allan,
    const UnitStaticAllan* unit_static);
// After the stand fit whose noise is `result`: whether the static recording's curves, taken as
// a bound, bounded the wander its sigmas allow for ("bound"), or why not (the run shows a
// wander of its own; its sigmas allow for none); whether the floor they put under the
// correlation time stood ("floor") or was set aside ("nothing"); and where the recording's own
// long dwell put that floor instead, whether the fit kept it. Once per use. Every caller of
// take_unit_wander_with_static_recording calls it before saying what the recording gave.
void settle_unit_static_use(UnitStaticRecordingUse& use, const NoiseFinding& result);
// After a diagnosis offered the floor under the correlation time that the unit's static
// recording's curves put (use.tau_floor_s; DiagnoseOptions::unit_static_tau_floor_s): whose
// floor it took (`floor_from`, `outcome`: Diagnosis::tau_floor_from, tau_floor_outcome; `noise`
// its noise finding), and so whether it estimated the wander under that floor ("floor"), or
// estimated one there beyond the class bound, set it aside where its positions do not show the
// wander at those times, could not check the model, took the recording's own higher floor or
// the wander the recording's own long stretch pins ("nothing"). `fit_said`: use.why already
// says the floor and what the norm fit made of it. Nothing where the static recording pinned a
// wander or put no floor, or a wander was given.
void say_diagnosis_static_tau_floor(UnitStaticRecordingUse& use, const std::string& floor_from,
                                    const std::string& outcome, const NoiseFinding& noise,
                                    bool fit_said);
// `unit_static_recording` in the fit JSON, and the report's line on it.
nlohmann::json unit_static_recording_json(const UnitStaticRecordingUse& use);
std::string unit_static_recording_words(const UnitStaticRecordingUse& use);
// Its name in words: "the unit's static recording FILE (2 h static)".
std::string unit_static_recording_name(const UnitStaticRecordingUse& use);

// The result at another threshold, against the main one.
struct ThresholdStability {
  double factor = 1;
  std::size_t intervals = 0;
  Eigen::Matrix<double, 9, 1> values = Eigen::Matrix<double, 9, 1>::Zero();  // compensation
  std::vector<std::string> moved;  // parameters that moved by more than 1 sigma
  std::string error;               // the refit failed (too few intervals...)
};

struct NormCalibration {
  StaticDetection detection;
  NormFit fit;
  std::vector<ThresholdStability> stability;
  // Median over the intervals of curve_standard_error / (sigma / sqrt(n)) per axis: by how
  // much white noise would have understated a static mean's error within its interval.
  Vec3 understated_by = Vec3::Ones();
  std::vector<std::string> notes;
  std::optional<UnitStaticRecordingUse> unit_static_recording;
};

// ug of the calibrated axes per input unit: the diagonal of the compensation (its cross
// terms, the misalignment, are a per cent at most), over g.
Vec3 ug_per_input_unit(const NormCompensation& k, double g_mps2);

// Each interval weighted with its curve error (what detection gave it, before any wander was
// taken out); an interval made without one (a caller's own) has its standard error taken as
// the curve's.
void take_curve_errors(std::vector<StaticInterval>& intervals);

// Each interval's standard error beside a Gauss-Markov wander `n` that a fit weights for
// between the intervals: its curve error (the pooled Allan deviation at its length, which
// holds the wander's share q^2 gauss_markov_allan_variance(tau, T)) less that share, never
// below sigma / sqrt(n). The GLS carries the wander through the covariance of the means;
// left in the errors as well, it counted twice (docs/calibration.md, "Recordings without
// angles"). Without a wander in `n`, or without sigma / sqrt(n) to floor it at, an error is
// the curve's; an interval without a curve error has its standard_error taken as it.
// `ug_per_unit`: the calibrated axes' ug per input unit (ug_per_input_unit), which `n` is in.
void errors_beside_wander(std::vector<StaticInterval>& intervals, const NoiseFinding& n,
                          const Vec3& ug_per_unit);

// fit_norm of static intervals each weighted by its error beside the wander the fit weights
// for between them (errors_beside_wander, from their curve errors), redone until the wander
// settles: what `standcal fit --method norm` fits. Sets each interval's standard_error to the
// one the fit used.
NormFit fit_beside_wander(std::vector<StaticInterval>& intervals, double g_mps2, InputUnits units,
                          const NormFitOptions& options = {});

// By how much sigma/sqrt(n) understated each interval mean's error under the noise model:
// the colour within the interval (its Allan-deviation standard error) and the wander `n`
// between intervals together. Median over the intervals, per calibrated axis.
Vec3 white_noise_understatement(const std::vector<StaticInterval>& intervals,
                                const NormCompensation& k, double g, const NoiseFinding& n);

// "" or, where gaps in the static intervals' samples kept the fit from reading a wander off
// their curves (DwellGaps), the warning that says so, naming the recording.
std::string gaps_warning(const NormCalibration& c, const RawInput& input);

// Throws std::runtime_error with a plain message (no static interval, too few, no
// convergence).
NormCalibration calibrate_without_angles(const RawInput& input,
                                         const NormCalibrationOptions& options = {});

nlohmann::json norm_calibration_to_json(const NormCalibration& c, const RawInput& input);
// The fit's compensation in its own terms (bias, scale, misalignment, their sigmas and
// covariance), for the fit JSON; the file an INS loads is calib/compensation.hpp's.
nlohmann::json norm_compensation_to_json(const NormFit& fit, const RawInput& input);
std::string format_norm_report(const NormCalibration& c, const RawInput& input);

}  // namespace standcal
