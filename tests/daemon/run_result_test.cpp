// The fit of a finished run (daemon/standcald/run_result.cpp) on recordings written here: the
// unit's wander it weighs with comes from the recording's header, and from the configuration
// only for a recording whose header says nothing of it (header_silent_on_unit_wander).
#include "daemon/standcald/run_result.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "calib/programs.hpp"
#include "calib/simulator.hpp"
#include "tests/support/temp_dir.hpp"

namespace standcal::daemon {
namespace {

using nlohmann::json;

GivenWander wander_of(double size_ug, double tau_s) {
  GivenWander w;
  w.size_ug = size_ug;
  w.known_tau = KnownTau{tau_s, tau_s};
  return w;
}

// The result of a paper9 run whose recording's header carries `recorded` (nullopt: no keys),
// fitted by a daemon configured with `configured`.
// `size_key`: false drops unit_bias_instability_ug, as headers written before it was written
// always lack it.
json fit_of_run(const std::optional<GivenWander>& recorded, const GivenWander& configured,
                bool size_key = true) {
  test::TempDir dir{"standcal-run-result"};
  SimulationRequest req;
  req.program = paper9();
  req.truth = default_truth();
  req.timing.dwell_s = 10;
  req.seed = 9;
  req.unit_serial = "AU-R";
  Recording rec = simulate_run(req);
  if (recorded) set_unit_wander_header(rec, *recorded);
  if (!size_key)
    std::erase_if(rec.header, [](const auto& kv) { return kv.first == kHeaderUnitWanderUg; });
  RunRecord record;
  record.run_id = "20261206T000000Z-AU-R";
  record.unit_serial = "AU-R";
  record.g_local_mps2 = rec.g_local_mps2;
  record.recording_path = dir.file("recording.csv");
  write_recording(rec, record.recording_path);
  return fit_finished_run(record, dir.path(), configured, std::nullopt);
}

// A run begun by a daemon whose recordings did not yet carry the unit's wander (resumed after
// an upgrade, or diagnosed now) is fitted with the configured one, as it was then; a recording
// that carries one, or says it was begun with none, is fitted with its own, whatever the
// configuration says now.
TEST(RunResult, TheHeadersWanderComesFirstAndTheConfiguredOneStandsInForNone) {
  const json old_recording = fit_of_run(std::nullopt, wander_of(5, 600));
  const json& noise = old_recording["noise"];
  EXPECT_EQ(noise["model"], "gauss_markov") << noise.dump(2);
  EXPECT_DOUBLE_EQ(noise["wander_ug"][0].get<double>(), 5);
  EXPECT_EQ(noise["unit_wander_from"], "given");

  const json carried = fit_of_run(wander_of(3, 300), wander_of(5, 600));
  EXPECT_DOUBLE_EQ(carried["noise"]["wander_ug"][0].get<double>(), 3) << carried["noise"].dump(2);
  EXPECT_DOUBLE_EQ(carried["noise"]["tau_s"].get<double>(), 300);
  EXPECT_EQ(carried["noise"]["unit_wander_from"], "header");

  const json neither = fit_of_run(std::nullopt, GivenWander{});
  EXPECT_EQ(neither["noise"]["model"], "white") << neither["noise"].dump(2);

  // Begun with none configured (unit_bias_instability_ug 0), weighed with none, whatever the
  // configuration says now: as `standcal fit` of the recording weighs. Until 2026-12-07 it took
  // the configured one (a header without the wander's size was taken for an old run's).
  const json none_configured = fit_of_run(GivenWander{}, wander_of(5, 600));
  EXPECT_EQ(none_configured["noise"]["model"], "white") << none_configured["noise"].dump(2);
  EXPECT_FALSE(none_configured["noise"].contains("unit_wander_from"));

  // A header of the correlation time alone, as a daemon configured with only
  // unit.bias_instability_tau_s wrote before the size was written always: that time, not the
  // configured wander (the first draft of the rule above took the configured one).
  GivenWander tau_only;
  tau_only.known_tau = KnownTau{900, 900};
  const json at_tau = fit_of_run(tau_only, wander_of(5, 600), false);
  EXPECT_NE(at_tau["noise"]["how"].get<std::string>().find(
                "the unit's wander as this recording's header gives it"),
            std::string::npos)
      << at_tau["noise"].dump(2);
  EXPECT_FALSE(at_tau["noise"].contains("unit_wander_from")) << at_tau["noise"].dump(2);
}

}  // namespace
}  // namespace standcal::daemon
