#pragma once
// Figures for reports, drawn by PLplot (its svg device): stacked panels of points, lines
// and error bars, with highlighted x spans. A figure is data only; render_svg() draws it.
// PLplot keeps global state, so rendering is serialised inside this module.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace standcal::plot {

enum class SeriesStyle { points, line, points_and_line };

struct Series {
  std::string label;  // shown in the panel's legend; empty: not listed
  std::vector<double> x;
  std::vector<double> y;
  std::vector<double> y_sigma;  // empty, or one 1-sigma error bar per point
  SeriesStyle style = SeriesStyle::points;
};

struct Span {  // an x range drawn shaded, e.g. the located part of a mismatch
  double x_from = 0;
  double x_to = 0;
};

struct Panel {
  std::string title;
  std::string x_label;
  std::string y_label;
  bool log_x = false;  // log axes need positive data; non-positive points are skipped
  bool log_y = false;
  std::vector<Series> series;
  std::vector<Span> highlight;
  std::optional<double> y_reference;  // a horizontal reference line, e.g. 0
};

struct Figure {
  std::vector<Panel> panels;  // stacked top to bottom
  int width_px = 900;
  int panel_height_px = 300;
};

// Draws the figure as a standalone SVG document. Throws std::runtime_error naming the
// panel when it cannot be drawn (no panels, a series whose x and y lengths differ).
std::string render_svg(const Figure& figure);

// render_svg() without the XML prologue, ready to inline into an HTML page: every id it
// defines (and every reference to one) starts with `id_prefix` and '-', so the drawings of a
// page must have different prefixes. Throws std::invalid_argument unless the prefix is a
// letter followed by letters, digits, '-' or '_'.
std::string render_svg_inline(const Figure& figure, const std::string& id_prefix);

// Writes render_svg() to `path` (replaced atomically). Throws with the path on failure.
void write_svg(const Figure& figure, const std::filesystem::path& path);

}  // namespace standcal::plot
