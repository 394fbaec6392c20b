#include "calib/raw_input.hpp"

#include "calib/allan.hpp"
#include "calib/line_source.hpp"
#include "calib/order_statistics.hpp"
#include "calib/text.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace standcal {

namespace {
// Everything file-local lives in `input_reader`: the unity build concatenates calib/*.cpp,
// and the other files' anonymous namespaces hold helpers of the same names (trim...).
namespace input_reader {

constexpr double kMaxSampleCount = 1e12;     // a mean's samples: 11.6 days at 1 MHz
constexpr double kRelativeUnitWindow = 0.2;  // values within 20 % of 1 g tell the units
constexpr double kMinCountsNorm = 50;        // raw counts are integers at least this large

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// A standcal recording's samples, its units and gravity as raw input; its sample rate is
// the caller's to decide.
RawInput samples_of(const Recording& rec) {
  RawInput out;
  out.source = rec.source;
  out.format = InputFormat::standcal;
  out.units = InputUnits::mps2;
  out.units_how = "the " + std::string(kRecordingFormat) + " format (m/s^2)";
  out.g_mps2 = rec.g_local_mps2;
  out.g_given = rec.g_from_header;
  const std::size_t n = rec.samples.size();
  out.t_s.reserve(n);
  out.block.reserve(n);
  for (auto& a : out.axis) a.reserve(n);
  for (const RecordingSample& s : rec.samples) {
    out.t_s.push_back(s.t_s);
    for (int k = 0; k < 3; ++k) out.axis[static_cast<std::size_t>(k)].push_back(s.f_mps2[k]);
    out.block.push_back(s.pos);
  }
  out.warnings = rec.warnings;
  out.warmup_s = rec.warmup_s;
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

// A field without surrounding blanks and double quotes ("Acc X" as spreadsheets quote it).
std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

bool parse_number(std::string_view text, double& out) {
  text = unquote(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size() && std::isfinite(out);
}

bool parse_int(std::string_view text, int& out) {
  text = unquote(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) {
    if (!out.empty()) out += ", ";
    out += s;
  }
  return out;
}

double median_of(std::vector<double> v) { return v.empty() ? kNaN : median_in_place(v); }

// The file (or pipe) at `path`, whole.
std::string whole_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": read error");
  return buffer.str();
}

// ---------------------------------------------------------------- fields and delimiters

enum class Delim { comma, semicolon, tab, spaces };
// Order of preference when two delimiters split a line equally well.
constexpr std::array<Delim, 4> kDelims{Delim::comma, Delim::semicolon, Delim::tab, Delim::spaces};

std::string delim_name(Delim d) {
  switch (d) {
    case Delim::comma:
      return "','";
    case Delim::semicolon:
      return "';'";
    case Delim::tab:
      return "tabs";
    case Delim::spaces:
      return "spaces";
  }
  return "?";
}

// Splits a line into `fields` (views into the line): at every `,`, `;` or tab, or at runs
// of blanks (leading and trailing blanks then delimit nothing).
void split(std::string_view line, Delim d, std::vector<std::string_view>& fields) {
  fields.clear();
  if (d == Delim::spaces) {
    std::size_t i = 0;
    while (true) {
      while (i < line.size() && is_blank(line[i])) ++i;
      if (i >= line.size()) return;
      std::size_t j = i;
      while (j < line.size() && !is_blank(line[j])) ++j;
      fields.push_back(line.substr(i, j - i));
      i = j;
    }
  }
  const char c = d == Delim::comma ? ',' : d == Delim::semicolon ? ';' : '\t';
  std::size_t start = 0;
  while (true) {
    const std::size_t at = line.find(c, start);
    if (at == std::string_view::npos) {
      fields.push_back(line.substr(start));
      return;
    }
    fields.push_back(line.substr(start, at - start));
    start = at + 1;
  }
}

// ---------------------------------------------------------------- column names

enum class Unit { none, mps2, g, counts, s, ms, us, ns };

Unit unit_from_text(std::string_view text) {
  std::string u;
  for (char c : lower(text))
    if (c != ' ') u += c;
  static const std::array<std::pair<std::string_view, Unit>, 29> known{{
      {"m/s^2", Unit::mps2},   {"m/s2", Unit::mps2},    {"m/s\xC2\xB2", Unit::mps2},
      {"m/s/s", Unit::mps2},   {"m*s^-2", Unit::mps2},  {"ms^-2", Unit::mps2},
      {"m/sec^2", Unit::mps2}, {"mps2", Unit::mps2},    {"ms2", Unit::mps2},
      {"g", Unit::g},          {"g0", Unit::g},         {"counts", Unit::counts},
      {"count", Unit::counts}, {"cnt", Unit::counts},   {"lsb", Unit::counts},
      {"raw", Unit::counts},   {"adc", Unit::counts},   {"digits", Unit::counts},
      {"s", Unit::s},          {"sec", Unit::s},        {"secs", Unit::s},
      {"seconds", Unit::s},    {"ms", Unit::ms},        {"msec", Unit::ms},
      {"us", Unit::us},        {"\xC2\xB5s", Unit::us}, {"\xCE\xBCs", Unit::us},
      {"usec", Unit::us},      {"ns", Unit::ns},
  }};
  for (const auto& [name, unit] : known)
    if (u == name) return unit;
  return Unit::none;
}

// Unit suffixes of a normalised name (fx_mps2, t_ms, ax_raw).
constexpr std::array<std::pair<std::string_view, Unit>, 20> kUnitSuffixes{{
    {"_mps2", Unit::mps2},    {"_m_s2", Unit::mps2},  {"_m_s_2", Unit::mps2},
    {"_ms2", Unit::mps2},     {"_g", Unit::g},        {"_counts", Unit::counts},
    {"_count", Unit::counts}, {"_cnt", Unit::counts}, {"_lsb", Unit::counts},
    {"_raw", Unit::counts},   {"_adc", Unit::counts}, {"_s", Unit::s},
    {"_sec", Unit::s},        {"_secs", Unit::s},     {"_seconds", Unit::s},
    {"_ms", Unit::ms},        {"_msec", Unit::ms},    {"_us", Unit::us},
    {"_usec", Unit::us},      {"_ns", Unit::ns},
}};

// A header name, taken apart: "Acc X [m/s^2]" -> full "acc_x" (unit m/s^2);
// "fx_mps2" -> full "fx_mps2", base "fx" (unit m/s^2 from the suffix).
struct ColumnName {
  std::string original;  // as in the header, without blanks and quotes around it
  std::string full;      // lower case, separators as '_', bracketed unit removed
  Unit full_unit = Unit::none;
  std::string base;  // `full` without a unit suffix (== full when it has none)
  Unit base_unit = Unit::none;
};

std::string normalise(std::string_view s) {
  std::string out;
  for (char c : lower(trim(s))) {
    if (c == ' ' || c == '-' || c == '.' || c == '\t') c = '_';
    if (c == '_' && (out.empty() || out.back() == '_')) continue;
    out += c;
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out;
}

ColumnName analyse_name(std::string_view field) {
  ColumnName n;
  std::string_view text = unquote(field);
  n.original = std::string(text);
  if (!text.empty() && (text.back() == ']' || text.back() == ')')) {
    const char open = text.back() == ']' ? '[' : '(';
    const std::size_t at = text.rfind(open);
    if (at != std::string_view::npos && at > 0) {
      n.full_unit = unit_from_text(text.substr(at + 1, text.size() - at - 2));
      text = text.substr(0, at);
    }
  }
  n.full = normalise(text);
  n.base = n.full;
  n.base_unit = n.full_unit;
  for (const auto& [suffix, unit] : kUnitSuffixes) {
    if (n.full.size() > suffix.size() && n.full.ends_with(suffix)) {
      n.base = n.full.substr(0, n.full.size() - suffix.size());
      if (n.base_unit == Unit::none) n.base_unit = unit;
      break;
    }
  }
  return n;
}

// The accelerometer axis (0, 1, 2) a name stands for, or -1: fx, ax, acc_x, accx, accel_x,
// accelerometer_x, acceleration_x, a_x, x...
int axis_of(std::string_view name) {
  static constexpr std::array<std::string_view, 15> kPrefixes{"",
                                                              "f",
                                                              "f_",
                                                              "a",
                                                              "a_",
                                                              "acc",
                                                              "acc_",
                                                              "accel",
                                                              "accel_",
                                                              "accelerometer",
                                                              "accelerometer_",
                                                              "acceleration",
                                                              "acceleration_",
                                                              "accl",
                                                              "accl_"};
  if (name.empty()) return -1;
  const char last = name.back();
  if (last >= 'x' && last <= 'z') {
    const std::string_view head = name.substr(0, name.size() - 1);
    for (std::string_view p : kPrefixes)
      if (head == p) return last - 'x';
  }
  const char first = name.front();
  if (first >= 'x' && first <= 'z') {
    const std::string_view tail = name.substr(1);
    if (tail == "_acc" || tail == "_accel" || tail == "acc") return first - 'x';
  }
  return -1;
}

// A mean's axis: any axis name, or one with mean_/avg_ in front or _mean/_avg behind.
int mean_axis_of(std::string_view name) {
  if (const int a = axis_of(name); a >= 0) return a;
  for (std::string_view p : {"mean_", "avg_", "average_"})
    if (name.starts_with(p)) return axis_of(name.substr(p.size()));
  for (std::string_view s : {"_mean", "_avg", "_average"})
    if (name.ends_with(s)) return axis_of(name.substr(0, name.size() - s.size()));
  return -1;
}

// A standard error's axis: se_x, sem_fx, stderr_x, std_err_x, se_mean_x, x_se...
int se_axis_of(std::string_view name) {
  for (std::string_view p : {"se_", "sem_", "stderr_", "std_err_", "stderror_", "standard_error_"})
    if (name.starts_with(p)) return mean_axis_of(name.substr(p.size()));
  for (std::string_view s : {"_se", "_sem", "_stderr", "_std_err"})
    if (name.ends_with(s)) return mean_axis_of(name.substr(0, name.size() - s.size()));
  return -1;
}

bool is_time_name(std::string_view name) {
  for (std::string_view t : {"t", "time", "timestamp", "time_stamp", "sec", "secs", "seconds"})
    if (name == t) return true;
  return false;
}

bool is_count_name(std::string_view name) {
  for (std::string_view t :
       {"n", "samples", "count", "n_samples", "num_samples", "nsamples", "sample_count"})
    if (name == t) return true;
  return false;
}

// Seconds per unit of a time column; 1 when it names none.
double time_scale(Unit u) {
  switch (u) {
    case Unit::ms:
      return 1e-3;
    case Unit::us:
      return 1e-6;
    case Unit::ns:
      return 1e-9;
    default:
      return 1;
  }
}

bool is_force_unit(Unit u) { return u == Unit::mps2 || u == Unit::g || u == Unit::counts; }

InputUnits input_units(Unit u) {
  return u == Unit::mps2 ? InputUnits::mps2 : u == Unit::g ? InputUnits::g : InputUnits::counts;
}

// Which role a header name plays under `match` (axis_of, mean_axis_of...): tried on the
// whole name first ("sample_count"), then without its unit suffix ("fx" of "fx_mps2").
template <class Match>
int match_name(const ColumnName& n, Match match, Unit& unit) {
  if (const int a = match(n.full); a >= 0) {
    unit = n.full_unit;
    return a;
  }
  if (n.base != n.full) {
    if (const int a = match(n.base); a >= 0) {
      unit = n.base_unit;
      return a;
    }
  }
  return -1;
}

// The unit a column chosen by --columns names, if any (ax_g, "Acc X [m/s^2]", mean_x_raw).
Unit named_unit(const ColumnName& c) {
  for (Unit u : {c.base_unit, c.full_unit})
    if (is_force_unit(u)) return u;
  return Unit::none;
}

// ---------------------------------------------------------------- the reader

struct Line {
  std::string_view text;      // without '\n' and a trailing '\r'
  int number = 0;             // 1-based
  bool unterminated = false;  // the file's last line, without a newline
};

// The lines of the input, read as a stream (a file is never held whole: a one-hour,
// 100 Hz imu_tk file is 23 MB), with what this reader needs of looking back: while the
// layout is being found, every line read is kept, and the reader can go back to any of
// them; once the rows start (stop_keeping), a row's text is only valid until the next.
class LineFeed {
 public:
  explicit LineFeed(LineSource source) : source_(std::move(source)) {}

  bool next(Line& line) {
    if (replay_ < kept_.size()) {
      const Kept& k = kept_[replay_++];
      line = {k.text, k.number, k.unterminated};
      return true;
    }
    std::string_view text;
    if (!source_.next(text)) return false;
    line = {text, source_.line_number(), source_.unterminated()};
    if (keeping_) {
      kept_.push_back({std::string(text), line.number, line.unterminated});
      replay_ = kept_.size();
      line.text = kept_.back().text;
    }
    return true;
  }

  // Reads `line` (one read while keeping) again next.
  void rewind_to(const Line& line) {
    replay_ = static_cast<std::size_t>(line.number - kept_.front().number);
  }

  void stop_keeping() { keeping_ = false; }

  // Input bytes not yet read (for sizing storage), and read so far.
  std::size_t bytes_left() const {
    return source_.bytes_total() > source_.bytes_consumed()
               ? source_.bytes_total() - source_.bytes_consumed()
               : 0;
  }
  std::size_t bytes_read() const { return source_.bytes_consumed(); }

 private:
  struct Kept {
    std::string text;
    int number = 0;
    bool unterminated = false;
  };
  LineSource source_;
  std::deque<Kept> kept_;  // a deque: the kept texts never move
  std::size_t replay_ = 0;
  bool keeping_ = true;
};

struct CommentKey {
  std::string key;
  std::string value;
  int line = 0;
};

// Where the three axes, the time and the dwell index of the rows are.
struct Layout {
  Delim delim = Delim::comma;
  std::size_t fields = 0;
  int header_line = 0;  // 0: no header line (then first_row_line names the fields)
  int first_row_line = 0;
  std::array<int, 3> axis{-1, -1, -1};  // 0-based field indices
  int time = -1;
  double time_scale = 1;
  bool time_tentative = false;  // headerless column 1: a time only if it never decreases
  int pos = -1;
  bool drop_unterminated_last = false;  // standcal's rule: any last line without newline
  std::vector<std::string> names;       // field names for messages ("fx_mps2", "column 2")
  std::array<Unit, 3> name_units{Unit::none, Unit::none, Unit::none};
};

class Reader {
 public:
  // `text` is the input when it is held in memory (else `lines` come from the file
  // `source`, which read_full_recording then reads again).
  Reader(LineSource lines, std::optional<std::string_view> text, const std::string& source,
         const InputOptions& options)
      : lines_(std::move(lines)), text_(text), options_(options) {
    out_.source = source;
    out_.option_prefix = options.option_prefix;
  }

  RawInput run() {
    check_options();
    skip_preamble();
    body_offset_ = lines_.bytes_read();
    body_line_ = line_no_;
    read_comment_lines();
    Line first;
    if (!next_content_line(first)) {
      if (comments_seen_ == 0) fail_empty();
      fail(0, "no data: the file holds only comment lines");
    }
    InputFormat format = options_.format;
    if (format == InputFormat::automatic && standcal_marker_) format = InputFormat::standcal;
    switch (format) {
      case InputFormat::standcal:
        read_standcal(first);
        break;
      case InputFormat::means:
        read_means(first);
        break;
      default:
        read_samples_file(first, format);
        break;
    }
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail(int column, const std::string& what) const {
    throw RecordingError(out_.source, line_no_, column, what);
  }
  [[noreturn]] void fail_at(int line, int column, const std::string& what) const {
    throw RecordingError(out_.source, line, column, what);
  }

  std::string option(std::string_view name) const { return out_.option(name); }

  void check_options() const {
    if (options_.skip_lines < 0)
      throw std::invalid_argument(option("skip-lines") + " must be 0 or more");
    if (options_.rate_hz && !is_plausible_sample_rate(*options_.rate_hz))
      throw std::invalid_argument(option("rate-hz") + ": " +
                                  implausible_sample_rate_text(round_trip_text(*options_.rate_hz)));
    if (options_.g_mps2 && !(std::isfinite(*options_.g_mps2) && *options_.g_mps2 > 0))
      throw std::invalid_argument(option("g-mps2") + " must be a positive acceleration in m/s^2");
    if (!options_.columns.empty() && options_.columns.size() != 3)
      throw std::invalid_argument(option("columns") +
                                  " takes three columns (x, y, z) by name or 1-based "
                                  "number; " +
                                  std::to_string(options_.columns.size()) + " given");
  }

  // Next line without its newline; false at the end.
  bool next_line(Line& line) {
    if (!lines_.next(line)) return false;
    line_no_ = line.number;
    return true;
  }

  bool next_content_line(Line& line) {
    while (next_line(line))
      if (!trim(line.text).empty()) return true;
    return false;
  }

  // Reads `line` again next.
  void rewind_to(const Line& line) {
    lines_.rewind_to(line);
    line_no_ = line.number - 1;
  }

  [[noreturn]] void fail_empty() const {
    if (options_.skip_lines > 0)
      fail_at(std::max(line_no_, 1), 0,
              "nothing after the " + std::to_string(options_.skip_lines) +
                  " preamble lines skipped (" + option("skip-lines") + ")");
    fail_at(std::max(line_no_, 1), 0, "the file is empty");
  }

  void skip_preamble() {
    Line line;
    for (int i = 0; i < options_.skip_lines; ++i)
      if (!next_line(line)) fail_empty();
  }

  // Leading `#` lines: comments, some `# key: value` (g_local_mps2, sample_rate_hz, format).
  void read_comment_lines() {
    Line line;
    while (next_line(line)) {
      const std::string_view t = trim(line.text);
      if (t.empty()) continue;
      if (t.front() != '#') {
        rewind_to(line);
        return;
      }
      ++comments_seen_;
      const std::string_view body = trim(t.substr(1));
      const std::size_t colon = body.find(':');
      if (colon == std::string_view::npos || colon == 0) continue;
      CommentKey k{std::string(trim(body.substr(0, colon))),
                   std::string(trim(body.substr(colon + 1))), line.number};
      if (k.key == "format" && k.value.starts_with("standcal-recording/")) {
        if (k.value != kRecordingFormat && options_.format == InputFormat::automatic)
          fail_at(k.line, 0,
                  "unsupported format '" + k.value + "' (this reader reads " +
                      std::string(kRecordingFormat) + ")");
        standcal_marker_ = true;
      }
      comments_.push_back(std::move(k));
    }
  }

  // The number a `# key: value` comment line gives `key`, with that line; none without one.
  // A second line with the key, or a value that is no number, is refused at its line.
  std::optional<std::pair<CommentKey, double>> comment_number(std::string_view key) const {
    std::optional<std::pair<CommentKey, double>> found;
    for (const CommentKey& k : comments_) {
      if (k.key != key) continue;
      if (found) fail_at(k.line, 0, "header key '" + k.key + "' appears twice");
      double v = 0;
      if (!parse_number(k.value, v))
        fail_at(k.line, 0, "header '" + k.key + "': '" + k.value + "' is not a number");
      found.emplace(k, v);
    }
    return found;
  }

  // g_local_mps2 and sample_rate_hz from the comment lines.
  void apply_comment_keys() {
    if (const auto g = comment_number("g_local_mps2")) {
      const auto& [k, v] = *g;
      if (v < 9.7 || v > 9.9)
        fail_at(k.line, 0,
                "header 'g_local_mps2': " + k.value +
                    " m/s^2 is not a plausible local gravity (9.7 ... 9.9)");
      header_g_ = v;
    }
    if (const auto rate = comment_number("sample_rate_hz")) {
      const auto& [k, v] = *rate;
      if (!is_plausible_sample_rate(v))
        fail_at(k.line, 0, "header 'sample_rate_hz': " + implausible_sample_rate_text(k.value));
      header_rate_ = v;
      header_rate_line_ = k.line;
    }
  }

  // A standcal recording's `# warmup_s` (Recording::warmup_s, as the full reader takes it):
  // the front of position 0's block is the unit settling, in the Allan curves alone. Without
  // a pos column no block is position 0's, and the warm-up cannot be told from the rest.
  void apply_warmup_key(bool has_pos) {
    const auto warm_up = comment_number(kHeaderWarmupS);
    if (!warm_up) return;
    const auto& [k, v] = *warm_up;
    if (!(v >= 0 && v <= kMaxAbsTime_s))
      fail_at(k.line, 0,
              "header 'warmup_s': " + k.value + " s is not a warm-up time (0 ... 1e12 s)");
    if (has_pos) {
      out_.warmup_s = v;
    } else if (v > 0) {
      out_.warnings.push_back(out_.source + ":" + std::to_string(k.line) + ": header warmup_s " +
                              k.value +
                              " s is not used: without a 'pos' column no rows are position "
                              "1's, so its warm-up is read as samples like the rest");
    }
  }

  // ------------------------------------------------------------ standcal-recording/1

  void read_standcal(const Line& column_line) {
    out_.format = InputFormat::standcal;
    std::vector<std::string_view> names;
    split(column_line.text, Delim::comma, names);
    bool cmd1 = false;
    bool cmd2 = false;
    for (std::string_view n : names) {
      cmd1 = cmd1 || trim(n) == "alpha1_cmd_deg";
      cmd2 = cmd2 || trim(n) == "alpha2_cmd_deg";
    }
    if (cmd1 && cmd2) {
      read_full_recording();
      return;
    }
    for (const CommentKey& k : comments_)
      if (k.key == "format" && k.value != kRecordingFormat)
        fail_at(k.line, 0,
                "unsupported format '" + k.value + "' (this reader reads " +
                    std::string(kRecordingFormat) + ")");
    apply_comment_keys();
    Layout layout;
    layout.delim = Delim::comma;
    layout.header_line = column_line.number;
    layout.drop_unterminated_last = true;
    for (std::string_view n : names) layout.names.emplace_back(trim(n));
    layout.fields = names.size();
    const auto find = [&](std::string_view name) {
      int found = -1;
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (trim(names[i]) != name) continue;
        if (found >= 0)
          fail_at(column_line.number, static_cast<int>(i) + 1,
                  "column '" + std::string(name) + "' appears twice");
        found = static_cast<int>(i);
      }
      return found;
    };
    layout.time = find("t_s");
    layout.pos = find("pos");
    apply_warmup_key(layout.pos >= 0);
    if (options_.columns.empty()) {
      static constexpr std::array<std::string_view, 3> kForce{"fx_mps2", "fy_mps2", "fz_mps2"};
      for (int k = 0; k < 3; ++k) {
        layout.axis[static_cast<std::size_t>(k)] = find(kForce[static_cast<std::size_t>(k)]);
        if (layout.axis[static_cast<std::size_t>(k)] < 0)
          fail_at(column_line.number, 0,
                  "required column '" + std::string(kForce[static_cast<std::size_t>(k)]) +
                      "' is missing (a " + std::string(kRecordingFormat) +
                      " file without angle columns needs t_s, fx_mps2, fy_mps2 and fz_mps2)");
      }
    } else {
      std::vector<ColumnName> analysed;
      for (std::string_view n : names) analysed.push_back(analyse_name(n));
      layout.axis = chosen_columns(&analysed, names.size(), column_line.number);
      for (std::size_t k = 0; k < 3; ++k)
        layout.name_units[k] = named_unit(analysed[static_cast<std::size_t>(layout.axis[k])]);
    }
    if (layout.time < 0) fail_at(column_line.number, 0, "required column 't_s' is missing");
    read_rows(layout);
    list_ignored(layout);
    if (options_.units != InputUnits::automatic) {
      set_units_from_option();
    } else if (options_.columns.empty()) {
      out_.units = InputUnits::mps2;
      out_.units_how =
          "the " + std::string(kRecordingFormat) + " format (fx_mps2, fy_mps2, fz_mps2 in m/s^2)";
    } else {
      units_from_names_or_values(layout);
    }
    resolve_g(header_g_);
    resolve_rate();
  }

  // A recording with its angle columns: parse_recording reads it, the samples are copied.
  void read_full_recording() {
    Recording rec = read_recording_again();
    if (options_.rate_hz) rec.use_given_sample_rate(*options_.rate_hz, option("rate-hz"));
    RawInput samples = samples_of(rec);
    out_.t_s = std::move(samples.t_s);
    out_.axis = std::move(samples.axis);
    out_.block = std::move(samples.block);
    out_.warmup_s = samples.warmup_s;
    if (options_.units != InputUnits::automatic) {
      set_units_from_option();
    } else {
      out_.units = InputUnits::mps2;
      out_.units_how =
          "the " + std::string(kRecordingFormat) + " format (fx_mps2, fy_mps2, fz_mps2 in m/s^2)";
    }
    if (options_.g_mps2) rec.use_given_g(*options_.g_mps2, option("g-mps2"));
    out_.warnings.insert(out_.warnings.end(), rec.warnings.begin(), rec.warnings.end());
    out_.g_mps2 = rec.g_local_mps2;
    out_.g_given = rec.g_from_header;
    // The header's rate, else --rate-hz (both in rec now), else the steps'.
    out_.sample_rate_hz = rec.sample_rate_hz > 0 ? rec.sample_rate_hz : rate_from_steps();
    out_.recording = std::move(rec);
  }

  // The input from its start, through the recording reader (streamed when it is a file
  // and no preamble is skipped).
  Recording read_recording_again() const {
    if (!text_ && options_.skip_lines == 0) return read_recording(out_.source);
    const std::string whole = text_ ? std::string() : whole_text(out_.source);
    const std::string_view text = text_ ? *text_ : std::string_view(whole);
    if (options_.skip_lines == 0) return parse_recording(text, out_.source);
    // The preamble becomes blank lines, which the recording reader passes over: its
    // messages then name the lines of the file as it is.
    std::string shifted(static_cast<std::size_t>(body_line_), '\n');
    shifted.append(text.substr(body_offset_));
    return parse_recording(shifted, out_.source);
  }

  // ------------------------------------------------------------ samples: imu_tk, delimited

  // The delimiter that splits a line into numbers only, into the most fields; none when
  // the line is not a row of numbers (then it is a header line).
  static std::optional<Delim> numeric_delimiter(std::string_view line) {
    std::optional<Delim> best;
    std::size_t best_count = 0;
    std::vector<std::string_view> fields;
    for (Delim d : kDelims) {
      split(line, d, fields);
      std::size_t numbers = 0;
      bool all = true;
      for (std::string_view f : fields) {
        double v = 0;
        if (parse_number(f, v)) {
          ++numbers;
        } else if (!trim(f).empty()) {
          all = false;
          break;
        }
      }
      if (all && numbers > 0 && fields.size() > best_count) {
        best = d;
        best_count = fields.size();
      }
    }
    return best;
  }

  void read_samples_file(const Line& first, InputFormat format) {
    apply_comment_keys();
    const std::optional<Delim> numeric = numeric_delimiter(first.text);
    if (numeric) {
      if (format == InputFormat::imu_tk && *numeric != Delim::spaces)
        fail_at(
            first.number, 0,
            "imu_tk text is separated by spaces; this row is separated by " + delim_name(*numeric));
      out_.format = format != InputFormat::automatic ? format
                    : *numeric == Delim::spaces      ? InputFormat::imu_tk
                                                     : InputFormat::delimited;
      read_headerless(first, *numeric);
      return;
    }
    if (format == InputFormat::imu_tk)
      fail_at(first.number, 1,
              "imu_tk text holds rows of numbers `t x y z` only; this line is not numbers (a "
              "header line? read the file with " +
                  option("format") + " delimited)");
    out_.format = InputFormat::delimited;
    read_with_header(first);
  }

  // Rows of numbers without a header line: `t x y z` (imu_tk), `x y z` with --rate-hz, or
  // the columns --columns chooses by number.
  void read_headerless(const Line& first, Delim delim) {
    std::vector<std::string_view> fields;
    split(first.text, delim, fields);
    Layout layout;
    layout.delim = delim;
    layout.fields = fields.size();
    layout.first_row_line = first.number;
    for (std::size_t i = 0; i < fields.size(); ++i)
      layout.names.push_back("column " + std::to_string(i + 1));
    const std::string n = std::to_string(fields.size());
    if (!options_.columns.empty()) {
      layout.axis = chosen_columns(nullptr, fields.size(), first.number);
      const bool first_chosen =
          std::find(layout.axis.begin(), layout.axis.end(), 0) != layout.axis.end();
      if (!time_rate() && !first_chosen) {
        layout.time = 0;
        layout.time_tentative = true;
      }
    } else if (fields.size() == 4) {
      layout.time = 0;
      layout.axis = {1, 2, 3};
    } else if (fields.size() == 3) {
      layout.axis = {0, 1, 2};
    } else if (fields.size() > 4) {
      fail_at(first.number, 0,
              "rows of " + n +
                  " numbers and no header line naming them: add a header line "
                  "(e.g. t,ax,ay,az,...) or pass " +
                  option("columns") + " X,Y,Z as 1-based column numbers");
    } else {
      fail_at(first.number, 0, "rows of " + n + " numbers: three accelerometer columns are needed");
    }
    if (layout.time < 0 && !time_rate())
      fail_at(first.number, 0,
              options_.columns.empty()
                  ? "rows of " + n + " numbers (x y z) without a time column: pass " +
                        option("rate-hz") + " with the sample rate"
                  : "no time column (column 1 is one of " + option("columns") + "): pass " +
                        option("rate-hz") + " with the sample rate");
    rewind_to(first);
    read_rows(layout);
    list_ignored(layout);
    units_from_names_or_values(layout);
    resolve_g(header_g_);
    resolve_rate();
  }

  // A header line naming the columns, then rows.
  void read_with_header(const Line& header) {
    Line row;
    if (!next_content_line(row)) fail_at(header.number, 0, "a header line but no data rows");
    const Delim delim = detect_delimiter(header, row);
    std::vector<std::string_view> fields;
    split(header.text, delim, fields);
    std::vector<ColumnName> names;
    for (std::string_view f : fields) names.push_back(analyse_name(f));
    Layout layout;
    layout.delim = delim;
    layout.fields = fields.size();
    layout.header_line = header.number;
    for (const ColumnName& c : names) layout.names.push_back(c.original);
    if (options_.columns.empty()) {
      layout.axis = axes_by_name(names, header.number, axis_of, layout.name_units);
    } else {
      layout.axis = chosen_columns(&names, fields.size(), header.number);
      for (std::size_t k = 0; k < 3; ++k)
        layout.name_units[k] = named_unit(names[static_cast<std::size_t>(layout.axis[k])]);
    }
    find_time(names, layout);
    if (layout.time < 0 && !time_rate())
      fail_at(header.number, 0,
              "no time column (columns: " + join(layout.names) + "): pass " + option("rate-hz") +
                  " with the sample rate");
    rewind_to(row);
    read_rows(layout);
    list_ignored(layout);
    units_from_names_or_values(layout);
    resolve_g(header_g_);
    resolve_rate();
  }

  void find_time(const std::vector<ColumnName>& names, Layout& layout) {
    std::vector<int> found;
    std::vector<Unit> units;
    for (std::size_t i = 0; i < names.size(); ++i) {
      const int index = static_cast<int>(i);
      if (std::find(layout.axis.begin(), layout.axis.end(), index) != layout.axis.end()) continue;
      Unit u = Unit::none;
      if (match_name(
              names[i], [](std::string_view s) { return is_time_name(s) ? 0 : -1; }, u) < 0)
        continue;
      found.push_back(index);
      units.push_back(u);
    }
    if (found.empty()) return;
    layout.time = found[0];
    layout.time_scale = time_scale(units[0]);
    if (found.size() > 1) {
      std::vector<std::string> others;
      for (std::size_t i = 1; i < found.size(); ++i)
        others.push_back("'" + layout.names[static_cast<std::size_t>(found[i])] + "'");
      out_.warnings.push_back(out_.source + ":" + std::to_string(layout.header_line) +
                              ": several time columns; using '" +
                              layout.names[static_cast<std::size_t>(found[0])] + "', ignoring " +
                              join(others));
    }
  }

  // The delimiter that splits the header into the most fields, as many as the first row.
  Delim detect_delimiter(const Line& header, const Line& row) const {
    std::vector<std::string_view> fields;
    std::optional<Delim> best;
    std::size_t best_count = 1;
    std::size_t widest = 0;
    Delim widest_delim = Delim::comma;
    for (Delim d : kDelims) {
      split(header.text, d, fields);
      const std::size_t in_header = fields.size();
      if (in_header > widest) {
        widest = in_header;
        widest_delim = d;
      }
      split(row.text, d, fields);
      if (fields.size() == in_header && in_header > best_count) {
        best = d;
        best_count = in_header;
      }
    }
    if (best) return *best;
    if (widest <= 1)
      fail_at(header.number, 0,
              "the header line holds one column name only; expected names "
              "separated by ',', ';', tabs or spaces");
    split(row.text, widest_delim, fields);
    fail_at(row.number, 0,
            "this row does not match the header line " + std::to_string(header.number) +
                ": split at " + delim_name(widest_delim) + " the header has " +
                std::to_string(widest) + " fields and this row " + std::to_string(fields.size()));
  }

  // The three columns named by --columns: 1-based numbers, or header names (any case).
  std::array<int, 3> chosen_columns(const std::vector<ColumnName>* names, std::size_t count,
                                    int line) const {
    std::array<int, 3> chosen{-1, -1, -1};
    std::vector<std::string> all;
    if (names)
      for (const ColumnName& c : *names) all.push_back(c.original);
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string_view want = trim(options_.columns[k]);
      int index = 0;
      if (!want.empty() &&
          std::all_of(want.begin(), want.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        if (!parse_int(want, index) || index < 1 || static_cast<std::size_t>(index) > count)
          fail_at(line, 0,
                  option("columns") + ": column " + std::string(want) + " is out of range (the " +
                      "rows have " + std::to_string(count) + " columns)");
        chosen[k] = index - 1;
      } else {
        if (!names)
          fail_at(line, 0,
                  option("columns") + " '" + std::string(want) +
                      "': the file has no header line, so columns are chosen by "
                      "1-based number");
        const std::string wanted = lower(want);
        const std::string wanted_norm = normalise(want);
        for (std::size_t i = 0; i < names->size(); ++i) {
          const ColumnName& c = (*names)[i];
          if (lower(c.original) != wanted && c.full != wanted_norm) continue;
          if (chosen[k] >= 0)
            fail_at(
                line, static_cast<int>(i) + 1,
                option("columns") + " '" + std::string(want) + "' matches more than one column");
          chosen[k] = static_cast<int>(i);
        }
        if (chosen[k] < 0)
          fail_at(line, 0,
                  option("columns") + ": no column named '" + std::string(want) +
                      "' (columns: " + join(all) + ")");
      }
      for (std::size_t j = 0; j < k; ++j)
        if (chosen[j] == chosen[k])
          fail_at(line, chosen[k] + 1,
                  option("columns") + " names column " + std::to_string(chosen[k] + 1) + " twice");
    }
    return chosen;
  }

  // The three accelerometer columns, found by name; refuses a missing or doubled axis.
  std::array<int, 3> axes_by_name(const std::vector<ColumnName>& names, int line,
                                  int (*role)(std::string_view), std::array<Unit, 3>& units) const {
    std::array<std::vector<int>, 3> found;
    std::array<Unit, 3> found_units{Unit::none, Unit::none, Unit::none};
    for (std::size_t i = 0; i < names.size(); ++i) {
      Unit u = Unit::none;
      const int a = match_name(names[i], role, u);
      if (a < 0) continue;
      found[static_cast<std::size_t>(a)].push_back(static_cast<int>(i));
      found_units[static_cast<std::size_t>(a)] = u;
    }
    std::vector<std::string> all;
    for (const ColumnName& c : names) all.push_back(c.original);
    if (found[0].empty() && found[1].empty() && found[2].empty()) {
      // A table of means read as samples: say so rather than ask for columns.
      bool means_columns = false;
      for (const ColumnName& c : names) {
        Unit u = Unit::none;
        means_columns = means_columns || match_name(c, mean_axis_of, u) >= 0;
      }
      fail_at(line, 0,
              "no accelerometer columns found among the header's columns (" + join(all) + "): " +
                  (means_columns ? std::string("they look like a table of static means: pass " +
                                               option("format") + " means")
                                 : std::string("pass " + option("columns") +
                                               " X,Y,Z (names or 1-based numbers)")));
    }
    std::array<int, 3> axis{};
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string letter(1, static_cast<char>('x' + k));
      if (found[k].empty())
        fail_at(line, 0,
                "no column for the " + letter +
                    " accelerometer among the header's "
                    "columns (" +
                    join(all) + "): pass " + option("columns") + " X,Y,Z");
      if (found[k].size() > 1) {
        const auto a = static_cast<std::size_t>(found[k][0]);
        const auto b = static_cast<std::size_t>(found[k][1]);
        fail_at(line, found[k][1] + 1,
                "columns '" + names[a].original + "' (column " + std::to_string(a + 1) + ") and '" +
                    names[b].original + "' (column " + std::to_string(b + 1) + ") both name the " +
                    letter + " accelerometer: choose with " + option("columns") + " X,Y,Z");
      }
      axis[k] = found[k][0];
      units[k] = is_force_unit(found_units[k]) ? found_units[k] : Unit::none;
    }
    return axis;
  }

  // Reads the rows of `layout` from the current position to the end.
  void read_rows(const Layout& layout) {
    std::vector<std::string_view> fields;
    Line line;
    reserve_rows(layout);
    lines_.stop_keeping();
    double previous_t = 0;
    double previous_t_as_read = 0;  // in the column's unit, for a message
    bool first = true;
    bool time_ok = true;
    while (next_content_line(line)) {
      if (first_data_line_ == 0) first_data_line_ = line.number;
      split(line.text, layout.delim, fields);
      if (line.unterminated && (layout.drop_unterminated_last || fields.size() != layout.fields ||
                                !row_is_complete(layout, fields))) {
        out_.warnings.push_back(out_.source + ":" + std::to_string(line.number) +
                                ": last line has no newline (a run cut off mid-write?); dropped");
        break;
      }
      if (fields.size() != layout.fields) {
        const std::string where = layout.header_line > 0
                                      ? "the header line " + std::to_string(layout.header_line)
                                      : "line " + std::to_string(layout.first_row_line);
        fail(0, "expected " + std::to_string(layout.fields) + " fields as in " + where +
                    ", found " + std::to_string(fields.size()));
      }
      for (std::size_t k = 0; k < 3; ++k)
        out_.axis[k].push_back(axis_number(layout, fields, layout.axis[k]));
      if (layout.pos >= 0) {
        const auto p = static_cast<std::size_t>(layout.pos);
        int pos = 0;
        if (!parse_int(fields[p], pos) || pos < 0)
          fail(layout.pos + 1, "column 'pos': '" + std::string(fields[p]) +
                                   "' is not a position index (an integer >= 0)");
        out_.block.push_back(pos);
      }
      if (layout.time < 0 || !time_ok) continue;
      const double t_as_read = field_number(layout, fields, layout.time);
      const double t = t_as_read * layout.time_scale;
      // Past this, the difference of two times can overflow and the rate read from the
      // steps become 0 Hz; no recording spans 30 000 years.
      if (!is_plausible_time(t))
        fail(layout.time + 1, "column '" + layout.names[static_cast<std::size_t>(layout.time)] +
                                  "': " + implausible_time_text(t));
      if (!first && t < previous_t) {
        const std::string name = layout.names[static_cast<std::size_t>(layout.time)];
        if (!layout.time_tentative)
          fail(layout.time + 1, "'" + name + "' goes backwards (" + round_trip_text(t_as_read) +
                                    " after " + round_trip_text(previous_t_as_read) +
                                    "); times must not decrease");
        time_ok = false;  // column 1 is no time after all
        time_broken_line_ = line.number;
        continue;
      }
      out_.t_s.push_back(t);
      previous_t = t;
      previous_t_as_read = t_as_read;
      first = false;
    }
    if (out_.axis[0].empty()) {
      if (layout.header_line > 0) fail_at(layout.header_line, 0, "a header line but no data rows");
      fail_at(std::max(line_no_, 1), 0, "no complete data rows");
    }
    if (layout.time < 0 || !time_ok) {
      const std::optional<double> rate = time_rate();
      if (!rate)
        fail_at(time_broken_line_, 1,
                "no time: column 1 decreases here, so it is not a time, and the rows have "
                "no other time column: pass " +
                    option("rate-hz") + " with the sample rate");
      out_.t_s.resize(out_.axis[0].size());
      for (std::size_t i = 0; i < out_.t_s.size(); ++i)
        out_.t_s[i] = static_cast<double>(i) / *rate;
      if (!out_.t_s.empty() && !is_plausible_time(out_.t_s.back())) refuse_rate_for_times(*rate);
      times_from_rate_ = true;
    }
  }

  // Storage for the rows, sized once from the bytes left and the first row's length (a
  // guess: reserved memory costs nothing until written, and a short guess only grows).
  void reserve_rows(const Layout& layout) {
    Line first;
    std::size_t row_bytes = 32;
    if (next_content_line(first)) {
      row_bytes = std::max<std::size_t>(first.text.size() + 1, 8);
      rewind_to(first);
    }
    const std::size_t expected = lines_.bytes_left() / row_bytes + 2;
    out_.t_s.reserve(expected);
    for (auto& a : out_.axis) a.reserve(expected);
    if (layout.pos >= 0) out_.block.reserve(expected);
  }

  double field_number(const Layout& layout, const std::vector<std::string_view>& fields,
                      int index) const {
    const std::string_view f = fields[static_cast<std::size_t>(index)];
    double v = 0;
    if (parse_number(f, v)) return v;
    std::string what = "column '" + layout.names[static_cast<std::size_t>(index)] + "': ";
    if (trim(f).empty())
      what += "empty field";
    else
      what += "'" + std::string(f) + "' is not a number";
    if (f.find(',') != std::string_view::npos) what += " (a decimal comma? write numbers with '.')";
    fail(index + 1, what);
  }

  // An accelerometer column's value: a number, and one an accelerometer can give.
  double axis_number(const Layout& layout, const std::vector<std::string_view>& fields,
                     int index) const {
    const double v = field_number(layout, fields, index);
    require_plausible(layout, index, v);
    return v;
  }

  // A value in the accelerometer's units (a sample, a mean, its standard error) in column
  // `index`: refused, naming the column, beyond any accelerometer's output.
  void require_plausible(const Layout& layout, int index, double v) const {
    if (!is_plausible_accelerometer_value(v))
      fail(index + 1, "column '" + layout.names[static_cast<std::size_t>(index)] +
                          "': " + implausible_accelerometer_value_text(v));
  }

  static bool row_is_complete(const Layout& layout, const std::vector<std::string_view>& fields) {
    double v = 0;
    for (int i : layout.axis)
      if (!parse_number(fields[static_cast<std::size_t>(i)], v)) return false;
    return layout.time < 0 || parse_number(fields[static_cast<std::size_t>(layout.time)], v);
  }

  void list_ignored(const Layout& layout) {
    for (std::size_t i = 0; i < layout.fields; ++i) {
      const int index = static_cast<int>(i);
      if (std::find(layout.axis.begin(), layout.axis.end(), index) != layout.axis.end()) continue;
      if (index == layout.pos || (index == layout.time && !times_from_rate_)) continue;
      out_.ignored_columns.push_back(layout.names[i]);
    }
  }

  // ------------------------------------------------------------ means tables

  void read_means(const Line& header) {
    out_.format = InputFormat::means;
    apply_comment_keys();
    if (numeric_delimiter(header.text))
      fail_at(header.number, 0,
              "a means table needs a header line naming its columns "
              "(mean_x, mean_y, mean_z; optional n, se_x, se_y, se_z)");
    Line row;
    if (!next_content_line(row)) fail_at(header.number, 0, "a header line but no data rows");
    const Delim delim = detect_delimiter(header, row);
    std::vector<std::string_view> fields;
    split(header.text, delim, fields);
    std::vector<ColumnName> names;
    for (std::string_view f : fields) names.push_back(analyse_name(f));
    Layout layout;
    layout.delim = delim;
    layout.fields = fields.size();
    layout.header_line = header.number;
    for (const ColumnName& c : names) layout.names.push_back(c.original);
    if (options_.columns.empty()) {
      layout.axis = means_by_name(names, header.number, layout.name_units);
    } else {
      layout.axis = chosen_columns(&names, fields.size(), header.number);
      for (std::size_t k = 0; k < 3; ++k)
        layout.name_units[k] = named_unit(names[static_cast<std::size_t>(layout.axis[k])]);
    }
    int count_column = -1;
    std::array<int, 3> se{-1, -1, -1};
    for (std::size_t i = 0; i < names.size(); ++i) {
      const int index = static_cast<int>(i);
      if (std::find(layout.axis.begin(), layout.axis.end(), index) != layout.axis.end()) continue;
      Unit u = Unit::none;
      if (match_name(
              names[i], [](std::string_view s) { return is_count_name(s) ? 0 : -1; }, u) >= 0) {
        if (count_column >= 0)
          fail_at(header.number, index + 1,
                  "two sample-count columns ('" +
                      layout.names[static_cast<std::size_t>(count_column)] + "' and '" +
                      layout.names[i] + "')");
        count_column = index;
        continue;
      }
      const int a = match_name(names[i], se_axis_of, u);
      if (a < 0) continue;
      if (se[static_cast<std::size_t>(a)] >= 0)
        fail_at(header.number, index + 1,
                "two standard-error columns for " + std::string(1, static_cast<char>('x' + a)));
      se[static_cast<std::size_t>(a)] = index;
    }
    const bool any_se = se[0] >= 0 || se[1] >= 0 || se[2] >= 0;
    for (std::size_t k = 0; k < 3; ++k)
      if (any_se && se[k] < 0)
        fail_at(header.number, 0,
                "no standard-error column for " + std::string(1, static_cast<char>('x' + k)) +
                    " although the others have one (columns: " + join(layout.names) + ")");
    rewind_to(row);
    lines_.stop_keeping();
    Line line;
    while (next_content_line(line)) {
      if (first_data_line_ == 0) first_data_line_ = line.number;
      split(line.text, delim, fields);
      if (line.unterminated &&
          (fields.size() != layout.fields || !row_is_complete(layout, fields))) {
        out_.warnings.push_back(out_.source + ":" + std::to_string(line.number) +
                                ": last line has no newline (cut off?); dropped");
        break;
      }
      if (fields.size() != layout.fields)
        fail(0, "expected " + std::to_string(layout.fields) + " fields as in the header line " +
                    std::to_string(header.number) + ", found " + std::to_string(fields.size()));
      StaticMeanRow r;
      r.line = line.number;
      for (std::size_t k = 0; k < 3; ++k)
        r.mean[static_cast<Eigen::Index>(k)] = axis_number(layout, fields, layout.axis[k]);
      if (count_column >= 0) {
        const double n = optional_number(layout, fields, count_column);
        if (!std::isnan(n)) {
          // Past the bound the count is a corrupted field (4e89 overflowed the interval's
          // integer count: the raw_input fuzz target, 2026-12-05).
          if (!(n > 0 && n <= kMaxSampleCount))
            fail(count_column + 1, "column '" +
                                       layout.names[static_cast<std::size_t>(count_column)] +
                                       "': the sample count must be positive and at most 1e12, "
                                       "not " +
                                       number_texts_apart(n, kMaxSampleCount).value);
          r.samples = n;
        }
      }
      if (any_se) {
        Vec3 e;
        int empty = 0;
        for (std::size_t k = 0; k < 3; ++k) {
          e[static_cast<Eigen::Index>(k)] = optional_number(layout, fields, se[k]);
          if (std::isnan(e[static_cast<Eigen::Index>(k)]))
            ++empty;
          else if (e[static_cast<Eigen::Index>(k)] < 0)
            fail(se[k] + 1, "column '" + layout.names[static_cast<std::size_t>(se[k])] +
                                "': a standard error cannot be negative");
          else
            require_plausible(layout, se[k], e[static_cast<Eigen::Index>(k)]);
        }
        if (empty == 0) {
          r.standard_error = e;
        } else if (empty == 3) {
          fail(se[0] + 1,
               "column '" + layout.names[static_cast<std::size_t>(se[0])] +
                   "': no standard errors on this row while the table has their columns");
        } else {
          for (std::size_t k = 0; k < 3; ++k)
            if (std::isnan(e[static_cast<Eigen::Index>(k)]))
              fail(se[k] + 1, "column '" + layout.names[static_cast<std::size_t>(se[k])] +
                                  "': empty field while the other standard errors are given");
        }
      }
      out_.means.push_back(r);
    }
    if (out_.means.empty()) fail_at(header.number, 0, "a header line but no data rows");
    for (std::size_t i = 0; i < layout.fields; ++i) {
      const int index = static_cast<int>(i);
      if (std::find(layout.axis.begin(), layout.axis.end(), index) != layout.axis.end() ||
          index == count_column || std::find(se.begin(), se.end(), index) != se.end())
        continue;
      out_.ignored_columns.push_back(layout.names[i]);
    }
    units_from_names_or_values(layout);
    resolve_g(header_g_);
  }

  // A number, or NaN for an empty field.
  double optional_number(const Layout& layout, const std::vector<std::string_view>& fields,
                         int index) const {
    if (unquote(fields[static_cast<std::size_t>(index)]).empty()) return kNaN;
    return field_number(layout, fields, index);
  }

  std::array<int, 3> means_by_name(const std::vector<ColumnName>& names, int line,
                                   std::array<Unit, 3>& units) const {
    std::array<std::vector<int>, 3> found;
    std::array<Unit, 3> found_units{Unit::none, Unit::none, Unit::none};
    for (std::size_t i = 0; i < names.size(); ++i) {
      Unit u = Unit::none;
      if (match_name(names[i], se_axis_of, u) >= 0) continue;  // "x_se" is no mean
      const int a = match_name(names[i], mean_axis_of, u);
      if (a < 0) continue;
      found[static_cast<std::size_t>(a)].push_back(static_cast<int>(i));
      found_units[static_cast<std::size_t>(a)] = u;
    }
    std::vector<std::string> all;
    for (const ColumnName& c : names) all.push_back(c.original);
    std::array<int, 3> axis{};
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string letter(1, static_cast<char>('x' + k));
      if (found[k].empty())
        fail_at(line, 0,
                "no mean column for " + letter + " (e.g. mean_" + letter +
                    ") among the header's columns (" + join(all) + "): pass " + option("columns") +
                    " X,Y,Z");
      if (found[k].size() > 1) {
        const auto a = static_cast<std::size_t>(found[k][0]);
        const auto b = static_cast<std::size_t>(found[k][1]);
        fail_at(line, found[k][1] + 1,
                "columns '" + names[a].original + "' and '" + names[b].original +
                    "' both name the mean of " + letter + ": choose with " + option("columns") +
                    " X,Y,Z");
      }
      axis[k] = found[k][0];
      units[k] = is_force_unit(found_units[k]) ? found_units[k] : Unit::none;
    }
    return axis;
  }

  // ------------------------------------------------------------ units, g, rate

  void set_units_from_option() {
    out_.units = options_.units;
    out_.units_how = option("units") + " " + std::string(to_string(options_.units));
  }

  void units_from_names_or_values(const Layout& layout) {
    if (options_.units != InputUnits::automatic) {
      set_units_from_option();
      return;
    }
    Unit named = Unit::none;
    int named_axis = -1;
    for (std::size_t k = 0; k < 3; ++k) {
      const Unit u = layout.name_units[k];
      if (u == Unit::none) continue;
      if (named != Unit::none && u != named)
        fail_at(layout.header_line, layout.axis[k] + 1,
                "columns '" +
                    layout.names[static_cast<std::size_t>(
                        layout.axis[static_cast<std::size_t>(named_axis)])] +
                    "' and '" + layout.names[static_cast<std::size_t>(layout.axis[k])] +
                    "' name different units: pass " + option("units") + " counts|g|mps2");
      named = u;
      named_axis = static_cast<int>(k);
    }
    if (named != Unit::none) {
      out_.units = input_units(named);
      std::vector<std::string> cols;
      for (int i : layout.axis) cols.push_back(layout.names[static_cast<std::size_t>(i)]);
      out_.units_how = "column names " + join(cols);
      return;
    }
    units_from_values();
  }

  void units_from_values() {
    const bool means = out_.format == InputFormat::means;
    const std::size_t n = means ? out_.means.size() : out_.axis[0].size();
    std::vector<double> norms(n);
    bool integers = true;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 v = means ? out_.means[i].mean : out_.sample(i);
      norms[i] = v.norm();
      for (int k = 0; k < 3 && integers; ++k) integers = v[k] == std::floor(v[k]);
    }
    const double median = median_of(norms);
    const std::string seen = "median |" + std::string(means ? "mean" : "sample") + "| " +
                             number_text(median) + " over " + std::to_string(n) +
                             (means ? " rows" : " samples");
    const bool near_mps2 =
        std::abs(median - kStandardGravity_mps2) <= kRelativeUnitWindow * kStandardGravity_mps2;
    const bool near_g = std::abs(median - 1) <= kRelativeUnitWindow;
    if (!integers && near_mps2) {
      out_.units = InputUnits::mps2;
      out_.units_how = "values: " + seen + ", near 9.80665 m/s^2";
    } else if (!integers && near_g) {
      out_.units = InputUnits::g;
      out_.units_how = "values: " + seen + ", near 1 g";
    } else if ((integers || means) && median >= kMinCountsNorm) {
      out_.units = InputUnits::counts;
      out_.units_how =
          "values: " + seen + (integers ? ", every value an integer" : "") + ", raw counts";
    } else {
      fail_at(first_data_line_, 0,
              "cannot tell the units of " + out_.source + " (" + seen +
                  (integers ? ", every value an integer: too small for raw counts, and g or "
                              "m/s^2 would not be whole numbers"
                            : ", neither near 1 g nor near 9.81 m/s^2") +
                  "): pass " + option("units") + " counts|g|mps2");
    }
  }

  void resolve_g(std::optional<double> from_file) {
    if (options_.g_mps2) {
      out_.g_mps2 = *options_.g_mps2;
      out_.g_given = true;
      if (from_file && *from_file != *options_.g_mps2)
        out_.warnings.push_back(g_option_replaces_header_warning(out_.source, *options_.g_mps2,
                                                                 *from_file, option("g-mps2")));
    } else if (from_file) {
      out_.g_mps2 = *from_file;
      out_.g_given = true;
    } else {
      out_.g_mps2 = kStandardGravity_mps2;
      out_.g_given = false;
      out_.warnings.push_back(out_.source +
                              ": no local gravity given (no '# g_local_mps2' header, no " +
                              option("g-mps2") +
                              "); assuming standard gravity 9.80665 m/s^2 (a wrong g "
                              "reads as a common scale-factor error)");
    }
  }

  // A rate so slow that the rows' times it makes pass the bound on any time (a corrupted
  // rate: 1e-300 Hz made times of 1e300 s), named where it was given.
  [[noreturn]] void refuse_rate_for_times(double rate_hz) const {
    const std::string why = number_text(rate_hz) + " Hz gives the last of " +
                            std::to_string(out_.t_s.size()) + " rows the time " +
                            number_texts_apart(out_.t_s.back(), kMaxAbsTime_s).value +
                            " s, beyond 1e12 s";
    if (options_.rate_hz) throw std::invalid_argument(option("rate-hz") + ": " + why);
    fail_at(header_rate_line_, 0, "header 'sample_rate_hz': " + why);
  }

  // The rate that makes times for rows without a time column.
  std::optional<double> time_rate() const {
    if (options_.rate_hz) return options_.rate_hz;
    return header_rate_;
  }

  void resolve_rate() {
    if (times_from_rate_) {
      out_.sample_rate_hz = *time_rate();
      // The option is the operator's word over the header (a header that misstates its
      // rate is mended so), but it is said: the rows' times, and every time constant the
      // fits estimate, follow it.
      if (options_.rate_hz && header_rate_ && *options_.rate_hz != *header_rate_)
        out_.warnings.push_back(rate_option_replaces_header_warning(*options_.rate_hz));
    } else if (header_rate_) {
      out_.sample_rate_hz = *header_rate_;
      if (options_.rate_hz && *options_.rate_hz != *header_rate_)
        out_.warnings.push_back(rate_option_not_used_warning(out_.source, *options_.rate_hz,
                                                             *header_rate_, option("rate-hz")));
    } else if (options_.rate_hz) {
      out_.sample_rate_hz = *options_.rate_hz;
    } else {
      out_.sample_rate_hz = rate_from_steps();
    }
  }

  std::string rate_option_replaces_header_warning(double given_hz) const {
    return out_.source + ":" + std::to_string(header_rate_line_) + ": " + option("rate-hz") + " " +
           round_trip_text(given_hz) + " replaces the header's sample_rate_hz " +
           round_trip_text(*header_rate_) +
           ": the rows have no time column, so their times are made from " +
           round_trip_text(given_hz) + " Hz";
  }

  double rate_from_steps() {
    const std::vector<double>& t = out_.t_s;
    if (t.size() < 2) return kNaN;
    std::vector<double> steps(t.size() - 1);
    for (std::size_t i = 1; i < t.size(); ++i) steps[i - 1] = t[i] - t[i - 1];
    const double step = median_of(std::move(steps));
    if (const std::string why = unusable_step_text(step); !why.empty()) {
      out_.warnings.push_back(out_.source + ": " + why + "; sample rate unknown (pass " +
                              option("rate-hz") + ")");
      return kNaN;
    }
    return 1 / step;
  }

  LineFeed lines_;
  std::optional<std::string_view> text_;  // the input, when held in memory
  const InputOptions& options_;
  int line_no_ = 0;
  std::size_t body_offset_ = 0;
  int body_line_ = 0;
  int first_data_line_ = 0;
  int time_broken_line_ = 0;
  bool times_from_rate_ = false;
  bool standcal_marker_ = false;
  int comments_seen_ = 0;
  std::vector<CommentKey> comments_;
  std::optional<double> header_g_;
  std::optional<double> header_rate_;
  int header_rate_line_ = 0;
  RawInput out_;
};

}  // namespace input_reader
}  // namespace

std::string input_option_name(const std::string& prefix, std::string_view name) {
  if (prefix.empty() || prefix.back() != '.') return "--" + prefix + std::string(name);
  std::string key = prefix + std::string(name);
  std::replace(key.begin() + static_cast<std::ptrdiff_t>(prefix.size()), key.end(), '-', '_');
  return key;
}

void drop_assumed_gravity_warning(RawInput& s) {
  std::erase_if(s.warnings, [](const std::string& w) { return is_assumed_gravity_warning(w); });
}

RawInput raw_input_of(const Recording& rec) {
  RawInput out = input_reader::samples_of(rec);
  try {
    out.sample_rate_hz = 1.0 / sample_period_s(rec);
  } catch (const std::exception& e) {
    // No rate header, and no two samples in one position or no step a unit makes.
    out.warnings.push_back(std::string(e.what()) + "; sample rate unknown");
  }
  return out;
}

namespace {

// One spelling per value, for printing and for parsing the command line.
template <typename E, std::size_t N>
using Spellings = std::array<std::pair<E, std::string_view>, N>;
constexpr Spellings<InputFormat, 5> kFormatSpellings{{{InputFormat::automatic, "auto"},
                                                      {InputFormat::standcal, "standcal"},
                                                      {InputFormat::imu_tk, "imu_tk"},
                                                      {InputFormat::delimited, "delimited"},
                                                      {InputFormat::means, "means"}}};
constexpr Spellings<InputUnits, 4> kUnitSpellings{{{InputUnits::automatic, "auto"},
                                                   {InputUnits::counts, "counts"},
                                                   {InputUnits::g, "g"},
                                                   {InputUnits::mps2, "mps2"}}};

template <typename E, std::size_t N>
std::string_view spelling_of(E value, const Spellings<E, N>& spellings) {
  for (const auto& [v, name] : spellings)
    if (v == value) return name;
  return "?";
}

template <typename E, std::size_t N>
E parse_spelling(std::string_view s, const Spellings<E, N>& spellings, const char* what) {
  std::string allowed;
  for (const auto& [v, name] : spellings) {
    if (s == name) return v;
    allowed += (allowed.empty() ? "" : ", ") + std::string(name);
  }
  throw std::invalid_argument("unknown input " + std::string(what) + " '" + std::string(s) + "' (" +
                              allowed + ")");
}

}  // namespace

std::string_view to_string(InputFormat f) { return spelling_of(f, kFormatSpellings); }
std::string_view to_string(InputUnits u) { return spelling_of(u, kUnitSpellings); }

InputFormat parse_input_format(std::string_view s) {
  return parse_spelling(s, kFormatSpellings, "format");
}
InputUnits parse_input_units(std::string_view s) {
  return parse_spelling(s, kUnitSpellings, "units");
}

RawInput parse_input(std::string_view text, const std::string& source,
                     const InputOptions& options) {
  return input_reader::Reader(LineSource::of_text(text), text, source, options).run();
}

RawInput read_input(const std::string& path, const InputOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw std::runtime_error(path + ": cannot open (a directory)");
  // A file is read as a stream; a pipe (which cannot be read twice, as a stand recording
  // is: once to find its format, once by the recording reader) is held whole.
  if (std::filesystem::is_regular_file(path, ec))
    return input_reader::Reader(LineSource::of_file(path), std::nullopt, path, options).run();
  const std::string text = input_reader::whole_text(path);
  return parse_input(text, path, options);
}

}  // namespace standcal
