// The figure module draws through PLplot's svg device; these tests read the SVG back.
#include "report/plot/figure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace standcal::plot {
namespace {

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

Figure residual_figure() {
  Panel panel;
  panel.title = "z residual against alpha2";
  panel.x_label = "alpha2 (deg)";
  panel.y_label = "residual (ug)";
  panel.y_reference = 0.0;
  panel.highlight.push_back({100.0, 140.0});
  Series before{"baseline",
                {0, 57.5, 122.5, 270},
                {3.0, -12.0, 15.0, -2.0},
                {1.0, 1.0, 1.0, 1.0},
                SeriesStyle::points};
  Series after{
      "with K2", {0, 57.5, 122.5, 270}, {0.5, -0.4, 0.2, 0.1}, {}, SeriesStyle::points_and_line};
  panel.series = {before, after};
  return Figure{{panel, panel}, 640, 240};
}

TEST(Figure, SvgCarriesTitlesLabelsAndLegendOfEveryPanel) {
  const std::string svg = render_svg(residual_figure());
  EXPECT_EQ(svg.find("<?xml"), 0u);
  EXPECT_EQ(count(svg, "z residual against alpha2"), 2u);
  EXPECT_GE(count(svg, "alpha2 (deg)"), 2u);
  EXPECT_GE(count(svg, "baseline"), 2u);
  EXPECT_GE(count(svg, "with K2"), 2u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

TEST(Figure, InlineSvgStartsAtTheSvgElement) {
  const std::string svg = render_svg_inline(residual_figure(), "figure");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
}

// PLplot numbers the clip paths of every drawing from 0: inlined into one page, two
// figures must not share ids (issue 20), and each reference stays inside its own figure.
TEST(Figure, InlineSvgIdsCarryTheirPrefix) {
  const std::string a = render_svg_inline(residual_figure(), "first");
  const std::string b = render_svg_inline(residual_figure(), "second");
  ASSERT_GT(count(a, " id=\""), 0u);
  EXPECT_EQ(count(a, " id=\"first-"), count(a, " id=\""));
  EXPECT_EQ(count(a, "url(#first-"), count(a, "url(#"));
  EXPECT_EQ(count(b, " id=\"second-"), count(b, " id=\""));
  EXPECT_EQ(count(b, "url(#second-"), count(b, "url(#"));
  EXPECT_THROW(render_svg_inline(residual_figure(), ""), std::invalid_argument);
  EXPECT_THROW(render_svg_inline(residual_figure(), "a\" onload=\"x"), std::invalid_argument);
}

TEST(Figure, LogAxesSkipNonPositivePointsInsteadOfFailing) {
  Panel allan{"Allan deviation, x", "tau (s)", "sigma (ug)", true, true, {}, {}, {}};
  allan.series.push_back(
      {"x", {0.0, 1, 10, 100}, {-1.0, 10, 3.2, 1.1}, {}, SeriesStyle::points_and_line});
  const std::string svg = render_svg(Figure{{allan}, 500, 300});
  EXPECT_NE(svg.find("Allan deviation, x"), std::string::npos);
}

TEST(Figure, HashInTextIsDrawnLiterallyNotAsPlplotEscape) {
  Panel panel{
      "position #9", "x", "y", false, false, {{"", {1, 2}, {1, 2}, {}, SeriesStyle::line}}, {}, {}};
  EXPECT_NE(render_svg(Figure{{panel}, 400, 200}).find("position #9"), std::string::npos);
}

TEST(Figure, MismatchedSeriesLengthsNameThePanelAndSeries) {
  Panel panel{"temperature",
              "T (degC)",
              "r (ug)",
              false,
              false,
              {{"y axis", {1, 2, 3}, {1, 2}, {}, SeriesStyle::points}},
              {},
              {}};
  try {
    render_svg(Figure{{panel}, 400, 200});
    FAIL() << "a series with 3 x and 2 y values was drawn";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("temperature"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("y axis"), std::string::npos) << e.what();
  }
  EXPECT_THROW(render_svg(Figure{}), std::runtime_error);
}

TEST(Figure, WriteSvgReplacesTheFile) {
  const auto path = std::filesystem::temp_directory_path() / "standcal-figure-test.svg";
  { std::ofstream(path) << "old"; }
  write_svg(residual_figure(), path);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("<svg"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace standcal::plot
