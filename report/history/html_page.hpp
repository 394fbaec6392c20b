#pragma once
// The pieces every standcal HTML document shares: escaping and one printable style sheet,
// so a certificate and a history page look alike and need no external file.
#include <cstdio>
#include <string>
#include <string_view>

namespace standcal::report {

inline std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// A number with a fixed count of decimals, "+" shown when `sign` is set.
inline std::string fixed(double v, int decimals = 2, bool sign = false) {
  char buf[64];
  std::snprintf(buf, sizeof buf, sign ? "%+.*f" : "%.*f", decimals, v);
  return buf;
}

// A number in its shortest form: 2 -> "2", 2.5 -> "2.5" (coverage factors).
inline std::string compact(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Report units as a reader writes them.
inline std::string unit_symbol(std::string_view unit) {
  if (unit == "ug") return "µg";
  if (unit == "arcsec") return "″";
  return std::string(unit);
}

// `extra_head`: more of <head> (a page's own <style>).
inline std::string html_page_start(const std::string& title, const std::string& extra_head = {}) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
         html_escape(title) +
         "</title>\n<style>\n"
         "body{font-family:'DejaVu Sans',Arial,sans-serif;max-width:980px;margin:2em "
         "auto;color:#222;line-height:1.4}\n"
         "h1{border-bottom:2px solid "
         "#333;padding-bottom:.2em}h2{margin-top:1.6em;border-bottom:1px solid #aaa}\n"
         "table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #bbb;padding:.25em "
         ".6em;text-align:left}\n"
         "td.num{text-align:right;font-variant-numeric:tabular-nums}th{background:#eee}\n"
         ".pass{background:#d9f2d9}.fail{background:#f8d0d0}.indeterminate,.not_evaluated{"
         "background:#fff1c2}\n"
         ".verdict{font-size:1.3em;font-weight:bold;padding:.4em "
         ".8em;display:inline-block;border:2px solid #333}\n"
         ".howto{background:#f4f4f8;padding:.6em 1em;border-left:4px solid #557}\n"
         "svg{max-width:100%;height:auto}@media "
         "print{h2{page-break-after:avoid}figure{page-break-inside:avoid}}\n"
         "</style>\n" +
         extra_head + "</head>\n<body>\n";
}

inline std::string html_page_end() { return "</body>\n</html>\n"; }

}  // namespace standcal::report
