// The diagnosis report (report/diagnosis): the per-position view it draws, the figures,
// the page, and `standcal diagnose --report`. Recordings come from the project's
// simulator with one effect of the catalog (docs/diagnosis.md's diagnostic programme).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "calib/averaging.hpp"
#include "calib/diagnosis/diagnosis.hpp"
#include "calib/invariant_estimator.hpp"
#include "calib/norm_calibration.hpp"
#include "calib/programs.hpp"
#include "calib/raw_input.hpp"
#include "calib/simulator.hpp"
#include "report/diagnosis/diagnosis_report.hpp"
#include "report/diagnosis/svg_compact.hpp"

namespace standcal {
namespace {

Recording simulate(const Program& program, const std::string& effect, const std::string& axis,
                   double value, std::uint64_t seed, double tau_s = 0,
                   double temp_rate_c_per_h = 0) {
  SimulationRequest req;
  req.program = program;
  req.truth = default_truth();
  req.truth.temperature.rate_c_per_h = temp_rate_c_per_h;
  if (!effect.empty()) req.truth.extra_physics.push_back({effect, axis, value, tau_s});
  req.seed = seed;
  req.timing.dwell_s = 10;
  req.timing.settle_s = 2;
  return simulate_run(req);
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos;
       at = text.find(what, at + what.size()))
    ++n;
  return n;
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

TEST(DiagnosisReport, K2OnZPredictedSignatureMatchesTheDiagnosisRefit) {
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_EQ(d.verdict, "explained");
  const std::vector<report::ResidualPoint> points = report::residual_points(d, rec);
  ASSERT_EQ(points.size(), 32u);
  // The report rebuilds the finding's effect from its value and model.md's
  // parametrisation; the part the baseline cannot absorb must be what the diagnosis's
  // own refit removed from the residuals (before - after), position by position.
  std::vector<double> predicted_z, predicted_x;
  for (const report::ResidualPoint& p : points) {
    ASSERT_EQ(p.before_ug.size(), 3u);
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_NEAR(p.predicted_ug[c], p.before_ug[c] - p.after_ug[c], 0.1 * p.before_sigma_ug[c])
          << "position " << p.pos << " component " << c;
    predicted_z.push_back(p.predicted_ug[2]);
    predicted_x.push_back(p.predicted_ug[0]);
  }
  // K2 acts on the z output: its signature is there, several standard errors big.
  EXPECT_GT(rms(predicted_z), 2 * points.front().before_sigma_ug[2]);
  EXPECT_LT(rms(predicted_x), 0.2 * rms(predicted_z));
}

// A stand effect acts through the geometry (the unit sits at the true angle, the model
// assumes the reading): the report's prediction must still match the diagnosis's refit.
TEST(DiagnosisReport, AngleSensorErrorPredictionMatchesTheDiagnosisRefit) {
  SimulationRequest req;
  req.program = diagnostic32();
  req.truth = default_truth();
  req.truth.extra_physics.push_back({"angle_sensor_error", "alpha1", 8, 0, 30});
  req.seed = 51;
  req.timing.dwell_s = 10;
  req.timing.settle_s = 2;
  const Recording rec = simulate_run(req);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_FALSE(d.findings.empty());
  ASSERT_EQ(d.findings.front().effect, "angle_sensor_error");
  double largest = 0;
  for (const report::ResidualPoint& p : report::residual_points(d, rec))
    for (std::size_t c = 0; c < 3; ++c) {
      EXPECT_NEAR(p.predicted_ug[c], p.before_ug[c] - p.after_ug[c], 0.2 * p.before_sigma_ug[c])
          << "position " << p.pos << " component " << c;
      largest = std::max(largest, std::abs(p.predicted_ug[c]) / p.before_sigma_ug[c]);
    }
  EXPECT_GT(largest, 2.0);  // there is a signature to draw
}

TEST(DiagnosisReport, PageHasThePlotsTheTablesAndNoExternalFiles) {
  // The unit warms by 2 degC over the run: the page has panels against temperature.
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31, 0, 10);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_EQ(d.verdict, "explained");
  const std::string html = report::diagnosis_html(d, rec);
  EXPECT_EQ(count(html, "<svg"), 3u);  // one figure per output axis
  for (const char* title : {"z output: residuals vs alpha1", "z output: residuals vs alpha2",
                            "z output: residuals vs u_z", "z output: residuals vs time",
                            "z output: residuals vs temperature", "x output: residuals vs time"})
    EXPECT_EQ(count(html, title), 1u) << title;
  EXPECT_EQ(count(html, "before (baseline model)"), 15u);  // the legend of every panel
  EXPECT_EQ(count(html, "predicted by the findings"), 15u);
  // Small enough to travel over the daemon's socket (run.diagnose with report: true).
  EXPECT_LT(html.size(), 768u * 1024u);
  EXPECT_NE(html.find("scale_nonlinearity_k2"), std::string::npos);
  EXPECT_NE(html.find("Verdict: explained"), std::string::npos);
  EXPECT_NE(html.find("class=\"hot\""), std::string::npos);  // located positions in the table
  EXPECT_EQ(html.find("<?xml"), std::string::npos);          // SVG inlined, not a document
  EXPECT_EQ(html.find("src="), std::string::npos);           // self-contained
  EXPECT_EQ(html.find("href="), std::string::npos);
}

TEST(DiagnosisReport, LocatedPositionsAreTheOnesBeyondThreeSigma) {
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31);
  const Diagnosis d = diagnose_recording(rec);
  const auto points = report::residual_points(d, rec);
  const auto figures = report::residual_figures(d, points);
  ASSERT_EQ(figures.size(), 3u);
  const plot::Panel& z_time = figures[2].panels[3];
  ASSERT_EQ(z_time.title.rfind("z output: residuals vs time", 0), 0u);
  std::size_t beyond = 0;
  for (const auto& p : points)
    beyond += std::abs(p.before_ug[2]) > 3 * p.before_sigma_ug[2] ? 1 : 0;
  ASSERT_GT(beyond, 0u) << "this recording's z residuals carry the mismatch";
  ASSERT_EQ(z_time.highlight.size(), beyond);
  for (const plot::Span& s : z_time.highlight) {  // each span covers a located position's dwell
    bool covers = false;
    for (const auto& p : points)
      covers = covers || (std::abs(p.before_ug[2]) > 3 * p.before_sigma_ug[2] &&
                          s.x_from <= p.t_start_s && s.x_to >= p.t_end_s);
    EXPECT_TRUE(covers) << s.x_from << " .. " << s.x_to;
  }
}

TEST(DiagnosisReport, CleanRecordingDrawsNoPrediction) {
  const Recording rec = simulate(diagnostic32(), "", "", 0, 21);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_EQ(d.verdict, "consistent");
  const auto figures = report::residual_figures(d, report::residual_points(d, rec));
  ASSERT_EQ(figures.size(), 3u);
  ASSERT_EQ(figures[0].panels.size(), 4u);  // alpha1, alpha2, u_x, time: the temperature stayed put
  for (const plot::Panel& p : figures[0].panels)
    EXPECT_EQ(p.series.size(), 2u) << p.title;  // before, after
  const std::string html = report::diagnosis_html(d, rec);
  EXPECT_EQ(html.find("predicted by the findings"), std::string::npos);
  EXPECT_NE(html.find("No finding."), std::string::npos);
  EXPECT_NE(html.find("no panel against temperature"), std::string::npos);
}

TEST(DiagnosisReport, Paper9ProposesPositions) {
  const Recording rec = simulate(paper9(), "scale_nonlinearity_k2", "z", -34, 5);
  const Diagnosis d = diagnose_recording(rec);
  ASSERT_EQ(d.verdict, "insufficient_redundancy");
  const std::string html = report::diagnosis_html(d, rec);
  EXPECT_NE(html.find("Proposed positions"), std::string::npos);
  EXPECT_EQ(count(html, "<svg"), 3u);
}

// A diagnosis whose baseline is the invariant joint fit (one residual per position, the
// projection L) is drawn per projection, without a gravity-component panel.
TEST(DiagnosisReport, InvariantBaselineIsDrawnInTheProjection) {
  const Recording rec = simulate(paper9(), "", "", 0, 6);
  Diagnosis d;
  d.verdict = "insufficient_redundancy";
  d.method = "joint";
  d.source = rec.source;
  d.baseline = fit_invariant_joint(average_positions(rec));
  d.final_fit = d.baseline;
  EXPECT_EQ(report::component_names(d), std::vector<std::string>{"L"});
  const auto figures = report::residual_figures(d, report::residual_points(d, rec));
  ASSERT_EQ(figures.size(), 1u);
  ASSERT_EQ(figures[0].panels.size(), 3u);  // alpha1, alpha2, time
  EXPECT_EQ(figures[0].panels[0].title.rfind("invariant projection L: residuals vs alpha1", 0), 0u);
  EXPECT_EQ(count(report::diagnosis_html(d, rec), "<svg"), 1u);
}

TEST(DiagnosisReport, SettlingTransientFigureFollowsTheRawSamples) {
  const Recording rec = simulate(diagnostic32(), "settling_transient", "y", 60, 15, 4);
  const Diagnosis d = diagnose_recording(rec);
  const auto figures = report::settling_figures(d, rec);
  ASSERT_EQ(figures.size(), 1u);
  const plot::Panel& panel = figures[0].panels.at(0);
  ASSERT_EQ(panel.series.size(), 2u);
  const plot::Series& data = panel.series[0];
  const plot::Series& predicted = panel.series[1];
  ASSERT_EQ(data.y.size(), predicted.y.size());
  ASSERT_GT(data.y.size(), 10u);
  // The binned samples follow the predicted decay: correlation near one.
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < data.y.size(); ++i) {
    mx += data.y[i];
    my += predicted.y[i];
  }
  mx /= static_cast<double>(data.y.size());
  my /= static_cast<double>(data.y.size());
  double sxy = 0, sxx = 0, syy = 0;
  for (std::size_t i = 0; i < data.y.size(); ++i) {
    sxy += (data.y[i] - mx) * (predicted.y[i] - my);
    sxx += (data.y[i] - mx) * (data.y[i] - mx);
    syy += (predicted.y[i] - my) * (predicted.y[i] - my);
  }
  EXPECT_GT(sxy / std::sqrt(sxx * syy), 0.9);
  EXPECT_GT(data.y.front(), 10.0);  // right after arrival the samples sit well above their mean
}

TEST(DiagnosisReport, ADiagnosisOfAnotherRecordingIsRejected) {
  const Diagnosis d = diagnose_recording(simulate(diagnostic32(), "", "", 0, 22));
  const Recording other = simulate(paper9(), "", "", 0, 22);
  EXPECT_THROW(report::residual_points(d, other), std::runtime_error);
}

TEST(DiagnosisReport, CliWritesTheReport) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("standcal-report-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string rec_path = (dir / "k2.csv").string(), html_path = (dir / "k2.html").string();
  write_recording(simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31), rec_path);
  const std::string cmd = std::string(STANDCAL_CLI_PATH) + " diagnose " + rec_path + " --report " +
                          html_path + " > " + (dir / "out.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(html_path);
  std::stringstream html;
  html << in.rdbuf();
  EXPECT_EQ(count(html.str(), "<svg"), 3u);
  EXPECT_NE(html.str().find("Verdict: explained"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// Everything a reader sees in the text of a drawing, in order.
std::vector<std::string> text_contents(const std::string& svg) {
  std::vector<std::string> out;
  for (std::size_t at = svg.find("<tspan"); at != std::string::npos;
       at = svg.find("<tspan", at + 1)) {
    const std::size_t from = svg.find('>', at) + 1;
    out.push_back(svg.substr(from, svg.find('<', from) - from));
  }
  return out;
}

TEST(SvgCompact, SameTextAndStrokesInAThirdOfTheBytes) {
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31);
  const Diagnosis d = diagnose_recording(rec);
  const auto figures = report::residual_figures(d, report::residual_points(d, rec));
  const std::string svg = plot::render_svg(figures[2]);
  const std::string small = report::compact_svg(svg);
  EXPECT_LT(small.size() * 3, svg.size());
  EXPECT_EQ(text_contents(small), text_contents(svg));
  EXPECT_EQ(small.substr(0, small.find("<svg")),
            svg.substr(0, svg.find("<svg")));  // prologue untouched
  // Every stroked segment survives: as many sub-path starts as stroked polylines before.
  std::size_t polylines = 0, moves = 0;
  for (std::size_t at = svg.find("<polyline"); at != std::string::npos;
       at = svg.find("<polyline", at + 1)) {
    const std::string tag = svg.substr(at, svg.find('>', at) - at);
    polylines += tag.find("fill=\"none\"") != std::string::npos ? 1 : 0;
  }
  for (std::size_t at = small.find(" d=\""); at != std::string::npos;
       at = small.find(" d=\"", at + 1))
    for (std::size_t i = at + 4; small[i] != '"'; ++i) moves += small[i] == 'M' ? 1 : 0;
  EXPECT_EQ(moves, polylines);
  for (std::size_t at = small.find("<polyline"); at != std::string::npos;
       at = small.find("<polyline", at + 1))
    EXPECT_EQ(small.substr(at, small.find('>', at) - at).find("fill=\"none\""),
              std::string::npos);  // all merged
  EXPECT_EQ(report::compact_svg("<svg><text>a  1.000000 b</text></svg>"),
            "<svg><text>a  1.000000 b</text></svg>");
  EXPECT_EQ(
      report::compact_svg("<svg>\n  <rect\n    x=\"1.504000\"\n    y=\"2.000000\"\n  />\n</svg>"),
      "<svg><rect x=\"1.5\" y=\"2\"/></svg>");
}

// ---- what a person reads (issue 15, item 5) ---------------------------------------------

// The row of the candidates table for one candidate, as the page prints it.
std::string candidate_row(const std::string& html, const std::string& effect,
                          const std::string& axis) {
  const std::string start = "<tr><td>" + effect + "</td><td>" + axis + "</td>";
  const std::size_t at = html.find(start);
  if (at == std::string::npos) return "";
  return html.substr(at, html.find("</tr>", at) - at);
}

CandidateTest candidate(const std::string& effect, const std::string& axis, bool testable,
                        double value, double sigma, const std::string& reason = "") {
  CandidateTest c;
  c.effect = effect;
  c.axis = axis;
  c.unit = "ug";
  c.testable = testable;
  c.reason = reason;
  c.value = value;
  c.sigma = sigma;
  return c;
}

// The numbers issue 15 found in the table: a candidate the programme cannot identify, and
// estimates that are not finite, are listed as not testable with their reason, never with
// a number; so is a candidate whose sigma is missing.
TEST(DiagnosisReport, UntestableCandidatesAreListedWithoutNumbers) {
  const Recording rec = simulate(diagnostic32(), "", "", 0, 21);
  Diagnosis d = diagnose_recording(rec);
  const CandidateTest implausible =
      candidate("cross_coupling", "yx", false, 12404302006548456.0, 7884205963143679.0,
                "its estimate is implausible for its kind");
  const CandidateTest no_sigma =
      candidate("angle_sensor_error", "alpha1", true, 2930995070440539.5, kNaN);
  const CandidateTest nan_value = candidate("bias_temperature", "z", true, kNaN, 5050);
  d.candidates = {implausible, no_sigma, nan_value};
  const std::string html = report::diagnosis_html(d, rec);
  for (const char* digits : {"12404302006548456", "7884205963143679", "2930995070440539", "5050"})
    EXPECT_EQ(html.find(digits), std::string::npos) << digits;
  EXPECT_NE(candidate_row(html, "cross_coupling", "yx")
                .find("not testable: its estimate is implausible for its kind"),
            std::string::npos);
  EXPECT_NE(candidate_row(html, "angle_sensor_error", "alpha1").find("not testable"),
            std::string::npos);
  EXPECT_NE(candidate_row(html, "bias_temperature", "z").find("not testable"), std::string::npos);
}

// Whole words nan / inf, as printf writes them ("nan", "-nan", "inf", "+inf").
bool has_non_finite_word(const std::string& text) {
  static const std::regex word("(^|[^A-Za-z0-9_])[+-]?(nan|inf|infinity)($|[^A-Za-z0-9_])",
                               std::regex::icase);
  return std::regex_search(text, word);
}

// A recording without temperature (the T column printed "nan"), a residual without a
// standard error, and a sentence from calib with a non-finite number: no nan or inf on the
// page.
TEST(DiagnosisReport, NoNanOrInfAnywhereOnThePage) {
  Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31);
  for (RecordingSample& s : rec.samples) s.temp_c = kNaN;
  rec.temp_ref_c.reset();
  Diagnosis d = diagnose_recording(rec);
  ASSERT_FALSE(d.findings.empty());
  d.baseline.residuals.front().sigma_g.setZero();
  d.summary.push_back("Two explanations fit about equally well: a (nan ug, chi2 gain -inf).");
  const std::string html = report::diagnosis_html(d, rec);
  ASSERT_FALSE(has_non_finite_word("nanometres, infinite care"));
  ASSERT_TRUE(has_non_finite_word("<td>-nan</td>"));
  EXPECT_FALSE(has_non_finite_word(html));
  EXPECT_NE(html.find("(n/a ug, chi2 gain n/a)"), std::string::npos);
  EXPECT_EQ(html.find("T (degC)"), std::string::npos) << "no temperature column without one";
}

TEST(DiagnosisReport, EmptySectionsAreNotPrinted) {
  const Recording rec = simulate(diagnostic32(), "", "", 0, 21);
  Diagnosis d = diagnose_recording(rec);
  d.not_tested.clear();
  d.located.clear();
  d.structure.clear();
  std::string html = report::diagnosis_html(d, rec);
  for (const char* heading : {"<h2>Not tested</h2>", "<h2>Where the mismatch is</h2>",
                              "<h2>Structure tests", "<h2>Proposed positions</h2>"})
    EXPECT_EQ(html.find(heading), std::string::npos) << heading;
  EXPECT_EQ(html.find("<ul></ul>"), std::string::npos);
  EXPECT_EQ(html.find("<table><tr><th>axis</th><th>against</th><th>z</th></tr></table>"),
            std::string::npos);
  d.not_tested = {"bias_temperature, scale_temperature: the recording has no temperature column"};
  html = report::diagnosis_html(d, rec);
  EXPECT_EQ(count(html, "<h2>Not tested</h2>"), 1u);
}

// Every inline <svg> of a page, in order.
std::vector<std::string> inline_svgs(const std::string& html) {
  std::vector<std::string> out;
  for (std::size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at)) {
    const std::size_t end = html.find("</svg>", at) + 6;
    out.push_back(html.substr(at, end - at));
    at = end;
  }
  return out;
}

// The values of `attribute="..."` in `text`, prefixed by `lead` (e.g. "url(#").
std::vector<std::string> quoted_after(const std::string& text, const std::string& lead, char stop) {
  std::vector<std::string> out;
  for (std::size_t at = text.find(lead); at != std::string::npos; at = text.find(lead, at + 1)) {
    const std::size_t from = at + lead.size();
    out.push_back(text.substr(from, text.find(stop, from) - from));
  }
  return out;
}

// Issue 20's blank panel: PLplot numbers the clip paths of every drawing from 0, so two
// inline SVGs defined the same ids and the second's url(#..) found the first's.
TEST(DiagnosisReport, InlinedFiguresHaveDisjointIds) {
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31);
  const std::string html = report::diagnosis_html(diagnose_recording(rec), rec);
  const std::vector<std::string> svgs = inline_svgs(html);
  ASSERT_EQ(svgs.size(), 3u);
  std::set<std::string> page_ids;
  for (const std::string& svg : svgs) {
    const std::vector<std::string> ids = quoted_after(svg, " id=\"", '"');
    ASSERT_FALSE(ids.empty());
    for (const std::string& id : ids) EXPECT_TRUE(page_ids.insert(id).second) << id;
    const std::set<std::string> own(ids.begin(), ids.end());
    for (const std::string& ref : quoted_after(svg, "url(#", ')'))
      EXPECT_EQ(own.count(ref), 1u) << ref << " is not defined in its own drawing";
  }
}

// A rectangle in the drawing's coordinates (PLplot's: y up).
struct Box {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  void take(double x, double y, double pad = 0) {
    x0 = std::min(x0, x - pad);
    x1 = std::max(x1, x + pad);
    y0 = std::min(y0, y - pad);
    y1 = std::max(y1, y + pad);
  }
  bool empty() const { return x0 > x1; }
  bool overlaps(const Box& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
};

// The corners of every "x,y" pair in a points or d attribute.
Box box_of_points(const std::string& list) {
  Box b;
  static const std::regex pair("(-?[0-9.]+),(-?[0-9.]+)");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), pair); it != std::sregex_iterator();
       ++it)
    b.take(std::stod((*it)[1]), std::stod((*it)[2]));
  return b;
}

// One panel of a compacted PLplot drawing: from its grid (drawn first, in the grid colour)
// to the next panel's. The legend is the white-filled background pllegend draws; the data
// points are the point glyphs drawn before it.
struct PanelShapes {
  Box frame, legend, points;
};

std::vector<PanelShapes> panels_of(const std::string& svg) {
  static const std::regex glyph(
      R"re(<text[^>]*font-size="([0-9.]+)"[^>]*matrix\(1 0 0 -1 ([0-9.-]+) ([0-9.-]+)\)[^>]*><tspan[^>]*>●<)re");
  std::vector<PanelShapes> out;
  const std::string grid = "stroke=\"#E1E1E1\"";
  for (std::size_t at = svg.find(grid); at != std::string::npos;) {
    const std::size_t next = svg.find(grid, at + 1);
    const std::string panel =
        svg.substr(at, next == std::string::npos ? std::string::npos : next - at);
    PanelShapes p;
    p.frame = box_of_points(panel.substr(0, panel.find("/>")));
    const std::size_t legend = panel.find("<polyline");
    if (legend != std::string::npos &&
        panel.find("fill=\"#FFFFFF\"", legend) < panel.find('>', legend))
      p.legend = box_of_points(panel.substr(legend, panel.find('>', legend) - legend));
    const std::string data = panel.substr(0, legend);
    for (auto it = std::sregex_iterator(data.begin(), data.end(), glyph);
         it != std::sregex_iterator(); ++it)
      p.points.take(std::stod((*it)[2]), std::stod((*it)[3]), std::stod((*it)[1]) / 2);
    out.push_back(p);
    at = next;
  }
  return out;
}

// Legends do not cover data: each panel's legend lies above its frame, clear of the points.
TEST(DiagnosisReport, LegendsDoNotCoverThePlottedPoints) {
  const Recording rec = simulate(diagnostic32(), "scale_nonlinearity_k2", "z", -34, 31, 0, 10);
  const std::string html = report::diagnosis_html(diagnose_recording(rec), rec);
  std::size_t panels = 0;
  for (const std::string& svg : inline_svgs(html)) {
    for (const PanelShapes& p : panels_of(svg)) {
      ++panels;
      ASSERT_FALSE(p.legend.empty()) << "panel " << panels << " has no legend";
      ASSERT_FALSE(p.points.empty()) << "panel " << panels << " has no points";
      EXPECT_FALSE(p.legend.overlaps(p.points)) << "panel " << panels;
      EXPECT_GE(p.legend.y0, p.frame.y1) << "panel " << panels << ": legend inside the frame";
    }
  }
  EXPECT_EQ(panels, 15u);
}

// A recording without angles (imu_tk's hand-held Xsens): the residuals against gravity's
// direction in the sensor frame and time, not stand angles it never had, and the Allan
// deviation the noise model was read from.
TEST(DiagnosisReport, ARecordingWithoutAnglesShowsOrientationAndTheAllanCurve) {
  InputOptions o;
  o.g_mps2 = 9.81744;
  const RawInput in =
      read_input(std::string(STANDCAL_TEST_DATA) + "/imu_tk_xsens/xsens_acc.mat", o);
  const NormCalibration cal = calibrate_without_angles(in);
  const Recording rec = calibrated_recording(in, cal);
  const std::string html = report::diagnosis_html(diagnose_without_angles(in, cal), rec);
  EXPECT_NE(html.find("attitude-free norm fit"), std::string::npos);
  EXPECT_NE(html.find("<h2>Noise: Allan deviation of the static intervals</h2>"),
            std::string::npos);
  EXPECT_NE(html.find("39 intervals pooled"), std::string::npos);
  for (const char* axis : {"u_x (g)", "u_y (g)", "u_z (g)", "time since the run started"})
    EXPECT_NE(html.find(axis), std::string::npos) << axis;
  EXPECT_EQ(html.find("outer axis"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
}

}  // namespace
}  // namespace standcal
