// A unit's history over several simulated calibrations, one with a bias drifting between
// them (ageing): the drift is flagged, each parameter is plotted with its ±U bars.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "calib/averaging.hpp"
#include "calib/invariant_estimator.hpp"
#include "report/history/history.hpp"
#include "tests/certificate/certificate_support.hpp"
#include "tests/certificate/html_query.hpp"

namespace standcal::test {
namespace {

using report::UnitHistory;

// Four calibrations 30 days apart; the true bias_x grows 40 µg between each.
UnitHistory drifting_unit() {
  UnitHistory h;
  h.unit_serial = "AU-0042";
  h.unit_type = "QA-2000";
  const char* dates[] = {"2026-01-10T09:00:00Z", "20260209T090000Z", "2026-03-11T09:00:00Z",
                         "2026-04-10T09:00:00Z"};
  for (int i = 0; i < 4; ++i) {
    TruthModel truth = default_truth();
    truth.unit.bias_g.x() += 40 * i * kUg;
    const FitResult fit =
        fit_invariant_joint(average_positions(simulated_recording("AU-0042", truth, 100 + i)));
    report::HistoryCalibration c;
    c.run_id = "run-" + std::to_string(i + 1);
    c.date_utc = dates[i];
    c.verdict = "pass";
    for (int p = 0; p < kUnitParameterCount; ++p) {
      c.parameters[static_cast<std::size_t>(p)].value =
          *fit.unit[static_cast<std::size_t>(p)].value * report_scale(p);
      c.parameters[static_cast<std::size_t>(p)].sigma =
          *fit.unit[static_cast<std::size_t>(p)].sigma * report_scale(p);
    }
    h.calibrations.push_back(c);
  }
  std::swap(h.calibrations[0], h.calibrations[2]);  // the page orders by date, not by input
  return h;
}

TEST(UnitHistory, FlagsTheInjectedDriftAtEveryStep) {
  const std::vector<report::HistoryDrift> drifts = report::find_drifts(drifting_unit());
  int bias_x_flags = 0, other_flags = 0;
  for (const report::HistoryDrift& d : drifts) {
    if (d.parameter == kBiasX) {
      ++bias_x_flags;
      EXPECT_NEAR(d.change, 40.0, 6 * d.change_sigma) << d.text;
      EXPECT_NEAR(d.days, 30.0, 1e-9);
    } else {
      ++other_flags;
    }
  }
  EXPECT_EQ(bias_x_flags, 3);
  // The rule flags |change| > 2 sigma: about 5 % of the 24 steady comparisons by chance.
  EXPECT_LE(other_flags, 4);
}

TEST(UnitHistory, ASourcesOwnVerdictsAreStatedNotJudgedAgain) {
  UnitHistory h = drifting_unit();
  h.changes.emplace();  // the source (the records database) found one change, on gamma23
  (*h.changes)[kGamma23] = {ParameterChange{"run-2", "run-3", 9.0, 2.0, 30.0, true},
                            ParameterChange{"run-3", "run-4", 1.0, 2.0, 30.0, false}};
  const std::vector<report::HistoryDrift> drifts = report::find_drifts(h);
  ASSERT_EQ(drifts.size(), 1u);  // not bias_x's three: those are the page's own rule's
  EXPECT_EQ(drifts[0].parameter, kGamma23);
  EXPECT_EQ(drifts[0].from_run_id, "run-2");
  EXPECT_DOUBLE_EQ(drifts[0].change, 9.0);
}

TEST(UnitHistory, PageHasATableTheDriftsAndOnePlotPerParameter) {
  const test::HtmlDocument page(report::render_history_html(drifting_unit()));
  EXPECT_EQ(page.count("//table[@id='calibrations']//tr[@data-run]"), 4u);
  const std::vector<std::string> order =
      page.texts("//table[@id='calibrations']//tr[@data-run]/@data-run");
  EXPECT_EQ(order, (std::vector<std::string>{"run-1", "run-2", "run-3", "run-4"}));
  EXPECT_EQ(page.count("//ul[@id='drifts']/li[@data-parameter='bias_x']"), 3u);
  EXPECT_EQ(page.count("//figure[@data-parameter]//svg"), 9u);
  EXPECT_EQ(page.count("//figure[@data-parameter='gamma23']//svg"), 1u);
  const std::vector<std::string> ids = page.texts("//@id");  // nine inline SVGs, one page
  EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()).size(), ids.size()) << "duplicate ids";
}

TEST(UnitHistory, ReadsBothUtcStampFormsAndRejectsOthers) {
  EXPECT_DOUBLE_EQ(report::utc_days("1970-01-02T12:00:00Z"), 1.5);
  EXPECT_DOUBLE_EQ(report::utc_days("20261121T223638Z"), report::utc_days("2026-11-21T22:36:38Z"));
  EXPECT_THROW(report::utc_days("21.11.2026"), std::runtime_error);
  EXPECT_THROW(report::utc_days("2026-02-30T00:00:00Z"), std::runtime_error);
  EXPECT_THROW(report::utc_days("2026-11-21T22:36:38"), std::runtime_error)
      << "no Z: not known to be UTC";
}

TEST(UnitHistory, UnmeasuredParametersAreShownNotPlottedAsZero) {
  UnitHistory h = drifting_unit();
  h.calibrations[1].parameters[kGamma13] = {};
  const test::HtmlDocument page(report::render_history_html(h));
  EXPECT_EQ(page.count("//table[@id='calibrations']//td[.='not measured']"), 1u);
}

}  // namespace
}  // namespace standcal::test
