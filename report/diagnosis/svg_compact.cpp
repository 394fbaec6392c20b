#include "report/diagnosis/svg_compact.hpp"

#include <algorithm>
#include <cctype>
#include <string_view>

namespace standcal::report {

namespace {

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

// Attribute whitespace collapsed to single spaces, no space before '>' or "/>", and
// whitespace-only runs between tags dropped. Text between tags is kept as it is.
std::string collapse_whitespace(std::string_view in) {
  std::string out;
  out.reserve(in.size());
  bool in_tag = false;
  std::size_t i = 0;
  while (i < in.size()) {
    const char c = in[i];
    if (!in_tag && c != '<') {  // text content: keep, unless it is only whitespace
      std::size_t end = in.find('<', i);
      if (end == std::string_view::npos) end = in.size();
      const std::string_view text = in.substr(i, end - i);
      bool blank = true;
      for (char t : text) blank = blank && is_space(t);
      if (!blank) out += text;
      i = end;
      continue;
    }
    if (c == '<') in_tag = true;
    if (in_tag && is_space(c)) {
      std::size_t j = i;
      while (j < in.size() && is_space(in[j])) ++j;
      const bool before_close =
          j < in.size() &&
          (in[j] == '>' || (in[j] == '/' && j + 1 < in.size() && in[j + 1] == '>'));
      if (!before_close) out += ' ';
      i = j;
      continue;
    }
    if (c == '>') in_tag = false;
    out += c;
    ++i;
  }
  return out;
}

void erase_all(std::string& s, std::string_view what) {
  std::string out;
  out.reserve(s.size());
  std::size_t from = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, from)) {
    out.append(s, from, at - from);
    from = at + what.size();
  }
  out.append(s, from, std::string::npos);
  s.swap(out);
}

// Inside tags, a decimal number keeps at most two decimals, without trailing zeros.
std::string round_coordinates(std::string_view in) {
  std::string out;
  out.reserve(in.size());
  bool in_tag = false;
  std::size_t i = 0;
  while (i < in.size()) {
    const char c = in[i];
    if (c == '<') in_tag = true;
    if (c == '>') in_tag = false;
    const bool starts_number = in_tag && std::isdigit(static_cast<unsigned char>(c)) &&
                               (i == 0 || !std::isalnum(static_cast<unsigned char>(in[i - 1])));
    if (!starts_number) {
      out += c;
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < in.size() && std::isdigit(static_cast<unsigned char>(in[j]))) ++j;
    out.append(in, i, j - i);
    if (j + 1 < in.size() && in[j] == '.' && std::isdigit(static_cast<unsigned char>(in[j + 1]))) {
      std::size_t k = j + 1;
      while (k < in.size() && std::isdigit(static_cast<unsigned char>(in[k]))) ++k;
      std::string decimals(in.substr(j + 1, std::min<std::size_t>(2, k - j - 1)));
      while (!decimals.empty() && decimals.back() == '0') decimals.pop_back();
      if (!decimals.empty()) out += "." + decimals;
      j = k;
    }
    i = j;
  }
  return out;
}

// `<polyline ATTRS points="P"/>` with a stroke and fill="none": its ATTRS and P.
bool stroked_polyline(std::string_view tag, std::string_view& attrs, std::string_view& points) {
  constexpr std::string_view open = "<polyline ", key = " points=\"", close = "\"/>";
  if (tag.substr(0, open.size()) != open || tag.size() < open.size() + close.size()) return false;
  if (tag.substr(tag.size() - close.size()) != close) return false;
  const std::size_t at = tag.find(key);
  if (at == std::string_view::npos ||
      tag.find("points=", at + key.size()) != std::string_view::npos)
    return false;
  attrs = tag.substr(open.size(), at - open.size());
  if (attrs.find("fill=\"none\"") == std::string_view::npos ||
      attrs.find("stroke=\"none\"") != std::string_view::npos)
    return false;
  points = tag.substr(at + key.size(), tag.size() - close.size() - at - key.size());
  return points.find('"') == std::string_view::npos;
}

// "x,y x,y x,y" as the sub-path "Mx,y Lx,y Lx,y".
void append_subpath(std::string& d, std::string_view points) {
  bool first = true;
  std::size_t i = 0;
  while (i < points.size()) {
    while (i < points.size() && points[i] == ' ') ++i;
    if (i >= points.size()) break;
    std::size_t j = points.find(' ', i);
    if (j == std::string_view::npos) j = points.size();
    if (!d.empty()) d += ' ';
    d += first ? 'M' : 'L';
    d.append(points, i, j - i);
    first = false;
    i = j;
  }
}

std::string merge_polylines(std::string_view in) {
  std::string out;
  out.reserve(in.size());
  std::string run_attrs, run_d;
  auto flush = [&] {
    if (run_attrs.empty()) return;
    out += "<path " + run_attrs + " d=\"" + run_d + "\"/>";
    run_attrs.clear();
    run_d.clear();
  };
  std::size_t i = 0;
  while (i < in.size()) {
    if (in[i] == '<') {
      std::size_t end = in.find('>', i);
      if (end == std::string_view::npos) end = in.size() - 1;
      const std::string_view tag = in.substr(i, end + 1 - i);
      std::string_view attrs, points;
      if (stroked_polyline(tag, attrs, points)) {
        if (attrs != run_attrs) {
          flush();
          run_attrs = attrs;
        }
        append_subpath(run_d, points);
      } else {
        flush();
        out += tag;
      }
      i = end + 1;
      continue;
    }
    std::size_t next = in.find('<', i);
    if (next == std::string_view::npos) next = in.size();
    flush();
    out.append(in, i, next - i);
    i = next;
  }
  flush();
  return out;
}

}  // namespace

std::string compact_svg(const std::string& svg) {
  // The XML prologue and doctype (if any) stay as they are: "1.0" is a version, not a coordinate.
  const std::size_t body = std::min(svg.find("<svg"), svg.size());
  std::string s = collapse_whitespace(std::string_view(svg).substr(body));
  // Attributes at their SVG default (opacity 1, no baseline shift, normal style, x 0).
  for (std::string_view attribute : {" fill-opacity=\"1.000000\"", " stroke-opacity=\"1.000000\"",
                                     " dominant-baseline=\"no-change\"", " font-style=\"normal\"",
                                     " font-weight=\"normal\"", " x=\"0.000000\""})
    erase_all(s, attribute);
  return svg.substr(0, body) + merge_polylines(round_coordinates(s));
}

}  // namespace standcal::report
