#pragma once
// PLplot's svg device writes one element per stroke segment, one attribute per line and
// six decimals per coordinate: a report page with fifteen panels would be ~2 MB, too big to
// send over the daemon's socket. This rewrites such an SVG into the same picture, smaller.
#include <string>

namespace standcal::report {

// The same drawing, smaller: whitespace between tags and attributes removed, attributes at
// their SVG default dropped, coordinates rounded to 0.01 px (inside tags only; text is
// untouched), and runs of consecutive stroked, unfilled polylines with the same style
// merged into one path of sub-paths (what is drawn does not change).
std::string compact_svg(const std::string& svg);

}  // namespace standcal::report
