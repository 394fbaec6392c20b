#include "report/plot/figure.hpp"

#include <plplot.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "calib/atomic_file.hpp"

namespace standcal::plot {
namespace {

// PLplot's stream table and current-stream pointer are process globals.
std::mutex plplot_mutex;

// cmap0 slots: 0 background, 1 axes and text, 2 shaded spans, 3 reference line, 4 grid,
// 5.. series colours (colour-blind-safe Tableau order).
constexpr int kBackground = 0, kInk = 1, kSpan = 2, kReference = 3, kGrid = 4, kFirstSeries = 5;
constexpr int kSeriesPalette[][3] = {{31, 119, 180}, {214, 39, 40},   {44, 160, 44},
                                     {255, 127, 14}, {148, 103, 189}, {140, 86, 75}};
constexpr double kPointScale = 0.6;
constexpr int kPaletteSize = static_cast<int>(std::size(kSeriesPalette));
constexpr const char* kPointGlyph = "\u25CF";  // filled circle, drawn as text by the svg device

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void take(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
};

// PLplot treats '#' as its text escape character.
std::string escape_text(const std::string& text) {
  std::string out;
  for (char c : text) {
    out += c;
    if (c == '#') out += '#';
  }
  return out;
}

double axis_value(double v, bool log_axis) {
  if (!log_axis) return v;
  return v > 0 ? std::log10(v) : std::numeric_limits<double>::quiet_NaN();
}

void validate(const Figure& figure) {
  if (figure.panels.empty()) throw std::runtime_error("plot: a figure needs at least one panel");
  for (const Panel& panel : figure.panels) {
    for (const Series& s : panel.series) {
      if (s.x.size() != s.y.size()) {
        throw std::runtime_error("plot: panel \"" + panel.title + "\", series \"" + s.label +
                                 "\": " + std::to_string(s.x.size()) + " x values but " +
                                 std::to_string(s.y.size()) + " y values");
      }
      if (!s.y_sigma.empty() && s.y_sigma.size() != s.y.size()) {
        throw std::runtime_error("plot: panel \"" + panel.title + "\", series \"" + s.label +
                                 "\": error bars must be given for every point or none");
      }
    }
  }
}

// The window in axis coordinates (log10 on log axes), padded so points do not sit on
// the frame; an empty or flat range is widened to something drawable.
void padded(Range& r) {
  if (r.empty()) r = {0.0, 1.0};
  double span = r.hi - r.lo;
  if (span <= 0) span = std::max(std::abs(r.hi) * 0.1, 1e-12);
  r.lo -= 0.05 * span;
  r.hi += 0.05 * span;
}

std::pair<Range, Range> panel_window(const Panel& panel) {
  Range x, y;
  for (const Series& s : panel.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      const double xv = axis_value(s.x[i], panel.log_x);
      if (!std::isfinite(xv)) continue;
      x.take(xv);
      const double sigma = s.y_sigma.empty() ? 0.0 : s.y_sigma[i];
      y.take(axis_value(s.y[i] - sigma, panel.log_y));
      y.take(axis_value(s.y[i] + sigma, panel.log_y));
      y.take(axis_value(s.y[i], panel.log_y));
    }
  }
  for (const Span& span : panel.highlight) {
    x.take(axis_value(span.x_from, panel.log_x));
    x.take(axis_value(span.x_to, panel.log_x));
  }
  if (panel.y_reference) y.take(axis_value(*panel.y_reference, panel.log_y));
  padded(x);
  padded(y);
  return {x, y};
}

void set_palette() {
  plscmap0n(kFirstSeries + kPaletteSize);
  plscol0(kBackground, 255, 255, 255);
  plscol0(kInk, 0, 0, 0);
  plscol0a(kSpan, 255, 200, 0, 0.3);
  plscol0(kReference, 128, 128, 128);
  plscol0(kGrid, 225, 225, 225);
  for (int i = 0; i < kPaletteSize; ++i) {
    plscol0(kFirstSeries + i, kSeriesPalette[i][0], kSeriesPalette[i][1], kSeriesPalette[i][2]);
  }
}

void draw_highlights(const Panel& panel, const Range& y) {
  plcol0(kSpan);
  for (const Span& span : panel.highlight) {
    const double x0 = axis_value(span.x_from, panel.log_x);
    const double x1 = axis_value(span.x_to, panel.log_x);
    if (!std::isfinite(x0) || !std::isfinite(x1)) continue;
    PLFLT xs[] = {x0, x1, x1, x0};
    PLFLT ys[] = {y.lo, y.lo, y.hi, y.hi};
    plfill(4, xs, ys);
  }
}

void draw_reference(const Panel& panel, const Range& x) {
  if (!panel.y_reference) return;
  const double yv = axis_value(*panel.y_reference, panel.log_y);
  if (!std::isfinite(yv)) return;
  plcol0(kReference);
  pllsty(2);
  PLFLT xs[] = {x.lo, x.hi};
  PLFLT ys[] = {yv, yv};
  plline(2, xs, ys);
  pllsty(1);
}

void draw_series(const Panel& panel, const Series& s, int colour) {
  std::vector<PLFLT> xs, ys, lo, hi;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double xv = axis_value(s.x[i], panel.log_x);
    const double yv = axis_value(s.y[i], panel.log_y);
    if (!std::isfinite(xv) || !std::isfinite(yv)) continue;
    xs.push_back(xv);
    ys.push_back(yv);
    const double sigma = s.y_sigma.empty() ? 0.0 : s.y_sigma[i];
    lo.push_back(axis_value(s.y[i] - sigma, panel.log_y));
    hi.push_back(axis_value(s.y[i] + sigma, panel.log_y));
  }
  if (xs.empty()) return;
  plcol0(colour);
  const auto n = static_cast<PLINT>(xs.size());
  if (s.style != SeriesStyle::points) plline(n, xs.data(), ys.data());
  if (s.style != SeriesStyle::line) {
    plschr(0, kPointScale);  // the glyph is text: its size follows the character height
    plstring(n, xs.data(), ys.data(), kPointGlyph);
    plschr(0, 1.0);
  }
  if (!s.y_sigma.empty()) {
    for (std::size_t i = 0; i < lo.size(); ++i) {  // a log axis cannot show a bar reaching <= 0
      if (!std::isfinite(lo[i])) lo[i] = ys[i];
    }
    plerry(n, xs.data(), lo.data(), hi.data());
  }
}

// The legend sits in a band above the frame, under the title, where it cannot cover data.
// Lengths in character heights (the current one, at scale 1).
constexpr double kLegendTextScale = 0.8;
constexpr double kLegendRowSpacing = 1.4;
constexpr double kLegendTextOffset = 0.3;    // between an entry's symbol and its text
constexpr double kLegendSymbolWidth = 0.02;  // of the frame's width
constexpr double kLegendGap = 0.3;           // between the frame and the legend
// PLplot has no public text measure: a character of a label is taken as this many
// character heights wide (pllegend's own Hershey measure of the reports' labels: 0.76).
constexpr double kCharWidth = 0.8;

struct Legend {
  std::vector<std::string> labels;  // PLplot-escaped
  std::vector<PLINT> colours, options;
  int columns = 0, rows = 0;
};

Legend legend_of(const Panel& panel) {
  Legend legend;
  for (std::size_t i = 0; i < panel.series.size(); ++i) {
    const Series& s = panel.series[i];
    if (s.label.empty()) continue;
    legend.labels.push_back(escape_text(s.label));
    legend.colours.push_back(kFirstSeries + static_cast<int>(i) % kPaletteSize);
    PLINT opt = 0;
    if (s.style != SeriesStyle::points) opt |= PL_LEGEND_LINE;
    if (s.style != SeriesStyle::line) opt |= PL_LEGEND_SYMBOL;
    legend.options.push_back(opt);
  }
  return legend;
}

std::size_t utf8_length(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80 ? 1 : 0;
  return n;
}

// The current subpage in millimetres and the character height.
struct Subpage {
  double width_mm = 1, height_mm = 1, char_mm = 0;
  double char_x() const { return char_mm / width_mm; }  // in normalized subpage coordinates
  double char_y() const { return char_mm / height_mm; }
};

Subpage current_subpage() {
  PLFLT x0 = 0, x1 = 1, y0 = 0, y1 = 1, default_mm = 0, char_mm = 0;
  plgspa(&x0, &x1, &y0, &y1);
  plgchr(&default_mm, &char_mm);
  return {x1 - x0, y1 - y0, char_mm};
}

// The legend's width in `columns` columns (normalized subpage coordinates), by pllegend's
// rule (PLplot 5.15, src/pllegend.c): every column as wide as the longest text, a 0.4
// character border each side, 2 characters between columns, a character's width taken as
// its height in normalized y.
double legend_width(const Legend& legend, int columns, double frame_width, const Subpage& page) {
  std::size_t longest = 0;
  for (const std::string& l : legend.labels) longest = std::max(longest, utf8_length(l));
  const double text =
      kCharWidth * kLegendTextScale * static_cast<double>(longest) * page.char_mm / page.width_mm;
  const double ch = page.char_y();
  const double column = text + kLegendTextOffset * ch + kLegendSymbolWidth * frame_width;
  return 0.8 * ch + (columns - 1) * 2.0 * ch + columns * column;
}

// As many entries per row as fit over the frame.
void arrange(Legend& legend, double frame_width, const Subpage& page) {
  const auto n = static_cast<int>(legend.labels.size());
  legend.columns = std::max(1, n);
  while (legend.columns > 1 &&
         legend_width(legend, legend.columns, frame_width, page) > frame_width)
    --legend.columns;
  legend.rows = n == 0 ? 0 : (n + legend.columns - 1) / legend.columns;
}

// A panel's frame in its subpage (normalized coordinates) and its title's distance above the
// frame (character heights): plvsta's margins of 8, 5, 5 and 5 character heights, the top one
// grown when the legend needs more than one row.
struct PanelLayout {
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  double title_disp = 2.0;
  double legend_offset = 0;  // the legend's gap above the frame, in frame heights
};

PanelLayout layout_panel(Legend& legend) {
  const Subpage page = current_subpage();
  PanelLayout l;
  l.x0 = 8 * page.char_x();
  l.x1 = 1 - 5 * page.char_x();
  l.y0 = 5 * page.char_y();
  arrange(legend, l.x1 - l.x0, page);
  const double band = legend.rows > 0 ? kLegendGap + legend.rows * kLegendRowSpacing : 0.0;
  l.title_disp = std::max(2.0, band + 1.4);
  l.y1 = 1 - std::max(5.0, l.title_disp + 2.3) * page.char_y();
  l.legend_offset = kLegendGap * page.char_y() / (l.y1 - l.y0);
  return l;
}

void draw_legend(const Legend& legend, const PanelLayout& layout) {
  if (legend.labels.empty()) return;
  const auto n = static_cast<PLINT>(legend.labels.size());
  std::vector<const char*> text, symbols(legend.labels.size(), kPointGlyph);
  for (const std::string& l : legend.labels) text.push_back(l.c_str());
  std::vector<PLINT> styles(legend.labels.size(), 1), symbol_numbers(legend.labels.size(), 1);
  std::vector<PLFLT> widths(legend.labels.size(), 1.0),
      symbol_scales(legend.labels.size(), kPointScale);
  PLFLT legend_width = 0, legend_height = 0;
  plcol0(kInk);
  // The background marks the legend in the drawing (white on white outside the frame).
  pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_ROW_MAJOR,
           PL_POSITION_TOP | PL_POSITION_OUTSIDE, 0.0, layout.legend_offset, kLegendSymbolWidth,
           kBackground, kInk, 1, legend.rows, legend.columns, n, legend.options.data(),
           kLegendTextOffset, kLegendTextScale, kLegendRowSpacing, 0.0, legend.colours.data(),
           text.data(), nullptr, nullptr, nullptr, nullptr, legend.colours.data(), styles.data(),
           widths.data(), legend.colours.data(), symbol_scales.data(), symbol_numbers.data(),
           symbols.data());
}

void draw_panel(const Panel& panel) {
  pladv(0);
  Legend legend = legend_of(panel);
  const PanelLayout layout = layout_panel(legend);
  plvpor(layout.x0, layout.x1, layout.y0, layout.y1);
  const auto [x, y] = panel_window(panel);
  plwind(x.lo, x.hi, y.lo, y.hi);
  draw_highlights(panel, y);
  plcol0(kGrid);
  plbox(panel.log_x ? "gl" : "g", 0, 0, panel.log_y ? "gl" : "g", 0, 0);
  plcol0(kInk);
  plbox(panel.log_x ? "bclnst" : "bcnst", 0, 0, panel.log_y ? "bclnstv" : "bcnstv", 0, 0);
  pllab(escape_text(panel.x_label).c_str(), escape_text(panel.y_label).c_str(), "");
  plmtex("t", layout.title_disp, 0.5, 0.5, escape_text(panel.title).c_str());
  draw_reference(panel, x);
  for (std::size_t i = 0; i < panel.series.size(); ++i) {
    draw_series(panel, panel.series[i], kFirstSeries + static_cast<int>(i) % kPaletteSize);
  }
  draw_legend(legend, layout);
}

// A temporary file PLplot writes into; removed when this goes out of scope.
class ScratchFile {
 public:
  ScratchFile() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "standcal-plot-XXXXXX").string();
    const int fd = mkstemp(pattern.data());
    if (fd < 0) throw std::runtime_error("plot: cannot create a temporary file in " + pattern);
    ::close(fd);
    path_ = pattern;
  }
  ~ScratchFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

void append_utf8(std::string& out, unsigned long code) {
  if (code < 0x80) {
    out += static_cast<char>(code);
  } else if (code < 0x800) {
    out += static_cast<char>(0xC0 | (code >> 6));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else if (code < 0x10000) {
    out += static_cast<char>(0xE0 | (code >> 12));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (code >> 18));
    out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  }
}

// PLplot's svg device writes every character of a label as a "&#x..;" reference; plain
// UTF-8 keeps the SVG small and lets a reader (or a test) search it for its labels.
// Characters with a meaning in XML stay references.
std::string decode_character_references(const std::string& svg) {
  std::string out;
  out.reserve(svg.size());
  std::size_t i = 0;
  while (i < svg.size()) {
    const std::size_t end = svg.compare(i, 3, "&#x") == 0 ? svg.find(';', i) : std::string::npos;
    if (end == std::string::npos || end - i > 10) {
      out += svg[i++];
      continue;
    }
    const unsigned long code = std::strtoul(svg.substr(i + 3, end - i - 3).c_str(), nullptr, 16);
    const bool xml_special =
        code == '&' || code == '<' || code == '>' || code == '"' || code == '\'';
    if (code == 0 || xml_special || code > 0x10FFFF) {
      out.append(svg, i, end + 1 - i);
    } else {
      append_utf8(out, code);
    }
    i = end + 1;
  }
  return out;
}

std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

bool valid_id_prefix(const std::string& prefix) {
  if (prefix.empty() || !std::isalpha(static_cast<unsigned char>(prefix.front()))) return false;
  return std::all_of(prefix.begin(), prefix.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

// PLplot's svg device numbers its clip paths from 0 in every drawing, and ids are unique per
// HTML page: two inlined drawings would share them, and the second's url(#..) would find the
// first's clip paths (losing its text where the two differ). Text cannot contain these
// patterns: its quotes stay character references (decode_character_references).
std::string prefix_ids(std::string svg, const std::string& prefix) {
  replace_all(svg, " id=\"", " id=\"" + prefix);
  replace_all(svg, "\"url(#", "\"url(#" + prefix);
  replace_all(svg, "href=\"#", "href=\"#" + prefix);
  return svg;
}

void draw_with_plplot(const Figure& figure, const std::filesystem::path& out) {
  PLINT previous_stream = 0, stream = 0;
  plgstrm(&previous_stream);
  plmkstrm(&stream);
  if (stream < 0) throw std::runtime_error("plot: PLplot has no free stream");
  plsdev("svg");
  plsfnam(out.c_str());
  const auto n_panels = static_cast<PLINT>(figure.panels.size());
  plspage(0, 0, figure.width_px, figure.panel_height_px * n_panels, 0, 0);
  set_palette();
  plssub(1, n_panels);
  plinit();
  plschr(0, 1.0);
  for (const Panel& panel : figure.panels) draw_panel(panel);
  plend1();
  plsstrm(previous_stream);
}

}  // namespace

std::string render_svg(const Figure& figure) {
  validate(figure);
  ScratchFile scratch;
  {
    std::lock_guard lock(plplot_mutex);
    draw_with_plplot(figure, scratch.path());
  }
  std::string svg = decode_character_references(read_all(scratch.path()));
  if (svg.find("<svg") == std::string::npos) {
    throw std::runtime_error("plot: PLplot's svg device wrote no drawing (" +
                             std::to_string(svg.size()) + " bytes)");
  }
  return svg;
}

std::string render_svg_inline(const Figure& figure, const std::string& id_prefix) {
  if (!valid_id_prefix(id_prefix))
    throw std::invalid_argument("plot: \"" + id_prefix +
                                "\" is not an id prefix (a letter, then letters, digits, - or _)");
  const std::string svg = render_svg(figure);
  return prefix_ids(svg.substr(svg.find("<svg")), id_prefix + "-");
}

void write_svg(const Figure& figure, const std::filesystem::path& path) {
  write_file_atomically(path.string(), render_svg(figure), "the figure");
}

}  // namespace standcal::plot
