#pragma once
// The fit as the stable JSON of `standcal fit --json` and as the text report a bench
// engineer reads (the compensation the INS loads is calib/compensation.hpp).
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "calib/fit_result.hpp"
#include "calib/recording.hpp"

namespace standcal {

// Where the fitted data came from, for the report header.
struct ReportContext {
  std::string source;  // recording path
  std::string unit_serial;
  std::string program;
  double g_local_mps2 = kStandardGravity_mps2;
  bool g_from_header = false;
  std::vector<std::string> warnings;
  std::vector<PositionAverage> averages;
  // What the unit's static recording gave the fit, in words (unit_static_recording_words;
  // empty where none was given): printed beneath the Noise line. report_context takes what
  // standcald's unit.static_recording gave the run (kHeaderUnitWanderSource).
  std::string unit_static_recording;
};

ReportContext report_context(const Recording& rec, std::vector<PositionAverage> averages);
// What standcald's unit.static_recording gave the run `rec` records, in words ("its run, by
// standcald's unit.static_recording: ..."; its header's kHeaderUnitWanderSource), or "" where
// the header says nothing. Said of the run: a later fit's own options may override it.
std::string run_unit_static_recording_words(const Recording& rec);
// The same line, where the header has one, into a result's JSON as `unit_wander_source`
// (standcald's run.result, `records import`'s stored result).
void put_unit_wander_source(nlohmann::json& result, const Recording& rec);

nlohmann::json fit_to_json(const FitResult& fit);
// `noise` of the fit and diagnosis JSON: the noise model a result was weighted with.
nlohmann::json noise_finding_json(const NoiseFinding& n);
std::string format_report(const FitResult& fit, const ReportContext& context);
// The report's `Noise:` line: the noise a fit weighted with, in the engineer's words.
// `static_recording_given`: the command was given the unit's static recording, and refuses
// --bias-instability-* beside it, so its advice on the correlation time says what would.
std::string noise_line(const NoiseFinding& n, bool static_recording_given);

}  // namespace standcal
