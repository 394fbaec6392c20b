#include "calib/recording.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

#include "calib/atomic_file.hpp"
#include "calib/decimal.hpp"
#include "calib/line_source.hpp"
#include "calib/text.hpp"

namespace standcal {

namespace {

constexpr std::size_t kToEnd = RecordingReader::kToEnd;

std::string locate(const std::string& source, int line, int column) {
  std::string where = source + ":" + std::to_string(line);
  if (column > 0) where += ": column " + std::to_string(column);
  return where;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

// A field as a spreadsheet may save it: quoted ("1.5", "x"). Numbers and names never hold
// a quote themselves, so the quotes are simply dropped.
std::string_view unquoted(std::string_view field) {
  field = trim(field);
  if (field.size() >= 2 && field.front() == '"' && field.back() == '"')
    field = trim(field.substr(1, field.size() - 2));
  return field;
}

bool parse_double(std::string_view text, double& out) {
  if (parse_plain_decimal(text, out)) return true;  // the common case, no trimming needed
  text = unquoted(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size() && std::isfinite(out);
}

bool parse_int(std::string_view text, int& out) {
  text = unquoted(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

enum Column : int {
  kT = 0,
  kPos,
  kA1Cmd,
  kA2Cmd,
  kA1,
  kA2,
  kFx,
  kFy,
  kFz,
  kTemp,
  kMountCol,
  kTArrive,
  kApproach,
  kColumnKinds
};

constexpr std::array<std::string_view, kColumnKinds> kColumnNames{
    "t_s",     "pos",     "alpha1_cmd_deg", "alpha2_cmd_deg", "alpha1_deg", "alpha2_deg", "fx_mps2",
    "fy_mps2", "fz_mps2", "temp_c",         "mount",          "t_arrive_s", "approach"};
constexpr int kRequiredColumns = 7;  // t_s, pos, both commanded angles, fx, fy, fz
constexpr std::array<Column, kRequiredColumns> kRequired{kT, kPos, kA1Cmd, kA2Cmd, kFx, kFy, kFz};

// Whether a number column's value lies where a measurement can (recording.hpp): beyond it
// the field is corrupted.
bool within_column(Column c, double v) {
  switch (c) {
    case kT:
    case kTArrive:
      return is_plausible_time(v);
    case kA1Cmd:
    case kA2Cmd:
    case kA1:
    case kA2:
      return std::abs(v) <= kMaxAbsAngle_deg;
    case kFx:
    case kFy:
    case kFz:
      return is_plausible_accelerometer_value(v);
    case kTemp:
      return is_plausible_temperature(v);
    default:
      return true;
  }
}

// A number column that may be empty (NaN in a sample).
bool is_optional(Column c) { return c == kA1 || c == kA2 || c == kTemp || c == kTArrive; }

// What is wrong with a value beyond its column's range.
std::string beyond_column_text(Column c, double v) {
  switch (c) {
    case kT:
    case kTArrive:
      return implausible_time_text(v);
    case kA1Cmd:
    case kA2Cmd:
    case kA1:
    case kA2:
      return number_texts_apart(v, kMaxAbsAngle_deg).value +
             " deg is not a stand angle (within +-1e6 deg, 2778 turns): a corrupted value?";
    case kTemp:
      return implausible_temperature_text(v);
    default:
      return implausible_accelerometer_value_text(v);
  }
}

// Splits a line at commas into `fields` (views into the line). One pass over the bytes:
// the fields are short, and a search call per field cost more than the scan (measured, as
// did a 16-byte SSE2 compare: docs/performance.md).
void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  const char* start = line.data();
  const char* const end = start + line.size();
  for (const char* p = start; p != end; ++p) {
    if (*p != ',') continue;
    fields.emplace_back(start, static_cast<std::size_t>(p - start));
    start = p + 1;
  }
  fields.emplace_back(start, static_cast<std::size_t>(end - start));
}

class Parser {
 public:
  Parser(LineSource& lines, const std::string& source, RecordingRowSink* sink)
      : lines_(lines), sink_(sink) {
    rec_.source = source;
  }

  // A reader of a later part of the same file (RecordingPartReader): `head`'s header and
  // columns, read from `lines` (which start at a line) as if the part were a file of its own.
  Parser(const Parser& head, LineSource& lines)
      : lines_(lines),
        sink_(nullptr),
        still_runs_(head.still_runs_),
        quick_fields_(head.quick_fields_),
        column_line_(head.column_line_),
        field_count_(head.field_count_),
        index_(head.index_) {
    rec_.source = head.rec_.source;
    for (StillRun& run : still_runs_) run.text.clear();
  }

  Recording run() {
    read_header();
    read_rows(kToEnd);
    return finish();
  }

  void set_sink(RecordingRowSink* sink) { sink_ = sink; }
  void set_cancel(const std::atomic<bool>* cancel) { cancel_ = cancel; }

  // The header and column line; the sink is given the recording without samples.
  const Recording& read_header() {
    read_column_line(read_header_lines());
    finish_header();
    if (sink_) sink_->header(rec_);
    return rec_;
  }

  Recording finish() {
    if (!rec_.g_from_header)
      rec_.warnings.push_back(rec_.source +
                              ": no '# g_local_mps2' header; assuming standard gravity 9.80665 "
                              "m/s^2 (a wrong g reads as a common scale-factor error)");
    return std::move(rec_);
  }

  int pos_field() const { return index_[kPos]; }

  // What a part's reading leaves for the check that it continues the rows before it.
  std::size_t rows() const { return rows_; }
  const RecordingSample& first_row() const { return first_; }
  const RecordingSample& last_row() const { return previous_; }
  const std::unordered_set<int>& positions() const { return finished_positions_; }
  const std::vector<std::string>& warnings() const { return rec_.warnings; }

 private:
  [[noreturn]] void fail(int column, const std::string& what) const {
    throw RecordingError(rec_.source, line_no_, column, what);
  }

  // Next line; false at end. Flags a final line lacking '\n'.
  bool next_line(std::string_view& line) {
    if (!lines_.next(line)) return false;
    line_no_ = lines_.line_number();
    last_line_truncated_ = lines_.unterminated();
    return true;
  }

  // The header's `# key: value` lines, up to the first other non-blank line, which is
  // returned (the column line).
  std::string_view read_header_lines() {
    std::string_view line;
    std::string storage;
    while (true) {
      if (!next_line(line)) fail(0, "no column-header line: the file ends inside its header");
      if (trim(line).empty()) continue;
      const std::optional<HeaderText> header = header_text(line, storage);
      if (!header) return line;
      require_utf8_header(line);
      parse_header_line(*header);
    }
  }

  // A header line as written, or as a spreadsheet saves it back: padded with the
  // separators of the empty cells beside it ("# format: standcal-recording/1,,,,,,"), and
  // quoted when its value holds a comma ("\"# stand: lab 2, stand A\",,,,,,"). Nothing when
  // the line is not a header line. Padding is told from a value that ends in ',' or ';' by
  // its length: a recording has at least 7 columns, so a spreadsheet adds 6 or more.
  // The text from its '#', and where that text is in the line as written, so that an error
  // names the file's column.
  struct HeaderText {
    std::string_view text;     // unquoted
    std::string_view written;  // the same in the line as written (its quotes doubled)
    int column_before = 0;     // the columns before it: blanks, an opening quote
  };
  std::optional<HeaderText> header_text(std::string_view as_written, std::string& storage) const {
    std::string_view line = trim(as_written);
    std::size_t separators = 0;
    while (separators < line.size() &&
           (line[line.size() - 1 - separators] == ',' || line[line.size() - 1 - separators] == ';'))
      ++separators;
    if (separators >= static_cast<std::size_t>(kRequiredColumns - 1))
      line = trim(line.substr(0, line.size() - separators));
    // Blanks and a quote: one byte a column.
    const auto column_of = [&](std::string_view part) {
      return static_cast<int>(part.data() - as_written.data());
    };
    if (!line.empty() && line.front() == '#') return HeaderText{line, line, column_of(line)};
    if (line.size() < 3 || line.substr(0, 2) != "\"#" || line.back() != '"') return std::nullopt;
    storage.clear();
    for (std::size_t i = 1; i + 1 < line.size(); ++i) {
      if (line[i] == '"' && line[i + 1] != '"')
        fail(column_of(line) + static_cast<int>(i) + 1, "a quote inside a quoted header line");
      storage += line[i];
      if (line[i] == '"') ++i;  // "" is one quote
    }
    const std::string_view written = line.substr(1, line.size() - 2);
    return HeaderText{storage, written, column_of(written)};
  }

  // A Latin-1 unit serial would reach the records database and every JSON output as
  // something else (U+FFFD), or not at all (PostgreSQL refuses the row). Judged on the line
  // as in the file, so that the byte named is the file's (a spreadsheet's quotes and
  // padding are taken off after).
  void require_utf8_header(std::string_view line_as_written) const {
    if (const auto at = first_non_utf8_byte(line_as_written))
      fail(static_cast<int>(*at + 1), "header line is not UTF-8 text: byte " +
                                          std::to_string(*at + 1) +
                                          " is not (save the file as UTF-8)");
  }

  void parse_header_line(const HeaderText& header) {
    const int before = header.column_before;
    std::string_view body = header.text.substr(1);
    if (body.empty() || body.front() != ' ')
      fail(before + 1, "header line must look like '# key: value'");
    body = trim(body);
    const std::size_t colon = body.find(':');
    if (colon == std::string_view::npos || colon == 0)
      fail(before + 2, "header line must look like '# key: value' (no ':' found)");
    // What the writer refuses, the reader refuses too: every recording read can be written.
    // Found in the text as written (a quote doubled there is one here, and no control
    // character), so that its column is the file's.
    if (auto c = find_control_character(header.written)) {
      c->character += static_cast<std::size_t>(before);  // one byte a column before it
      fail(static_cast<int>(c->character),
           "header line contains " + describe(*c) + "; header lines are printable text");
    }
    std::string key(trim(body.substr(0, colon)));
    std::string value(trim(body.substr(colon + 1)));
    if (seen_keys_.count(key)) fail(before + 3, "header key '" + key + "' appears twice");
    seen_keys_.insert(key);
    header_lines_[key] = line_no_;
    rec_.header.emplace_back(std::move(key), std::move(value));
  }

  void read_column_line(std::string_view line) {
    if (last_line_truncated_) fail(0, "the file ends at its column-header line (no samples)");
    column_line_ = line_no_;
    std::vector<std::string_view> names;
    split_fields(line, names);
    if (names.size() == 1) refuse_other_separator(line);
    index_.fill(-1);
    for (std::size_t i = 0; i < names.size(); ++i) {
      const std::string_view name = unquoted(names[i]);
      const int column = static_cast<int>(i) + 1;
      for (int k = 0; k < kColumnKinds; ++k) {
        if (kColumnNames[k] != name) continue;
        if (index_[k] >= 0) fail(column, "column '" + std::string(name) + "' appears twice");
        index_[k] = static_cast<int>(i);
      }
    }
    field_count_ = names.size();
    for (Column c : kRequired)
      if (index_[c] < 0)
        fail(0, "required column '" + std::string(kColumnNames[c]) + "' is missing");
    rec_.columns.alpha_measured = index_[kA1] >= 0 || index_[kA2] >= 0;
    rec_.columns.temp = index_[kTemp] >= 0;
    rec_.columns.mount = index_[kMountCol] >= 0;
    rec_.columns.t_arrive = index_[kTArrive] >= 0;
    rec_.columns.approach = index_[kApproach] >= 0;
    find_still_runs();
    plan_quick_rows();
  }

  // A file whose columns are separated by something else than ',' (a spreadsheet in a
  // locale with decimal commas saves ';'), said as such rather than "column missing".
  [[noreturn]] void refuse_other_separator(std::string_view line) const {
    for (const auto& [separator, name] : {std::pair{';', "';'"}, std::pair{'\t', "tabs"}}) {
      if (line.find(separator) == std::string_view::npos) continue;
      fail(0,
           "the columns are separated by " + std::string(name) +
               ", not ',': standcal-recording/1 is comma-separated with '.' as the decimal point "
               "(a spreadsheet set to a decimal-comma locale writes ';' and ','; save it as CSV "
               "with "
               "',' as the field separator and '.' decimals, e.g. LibreOffice Save As > Text CSV, "
               "Field delimiter ',', with an English (USA) locale)");
    }
    fail(0,
         "one column only: the column line must list t_s, pos, alpha1_cmd_deg, alpha2_cmd_deg, "
         "fx_mps2, fy_mps2, fz_mps2 separated by ','");
  }

  // A number column's value, refused where it is beyond what the column can hold
  // (recording.hpp: a corrupted field).
  double number(const std::vector<std::string_view>& f, Column c, bool optional) const {
    const int i = index_[c];
    if (i < 0) return kNoValue;
    if (optional && unquoted(f[static_cast<std::size_t>(i)]).empty()) return kNoValue;
    double v = 0;
    if (!parse_double(f[static_cast<std::size_t>(i)], v))
      fail(i + 1, "column '" + std::string(kColumnNames[c]) + "': '" +
                      std::string(f[static_cast<std::size_t>(i)]) + "' is not a number");
    if (!within_column(c, v))
      fail(i + 1, "column '" + std::string(kColumnNames[c]) + "': " + beyond_column_text(c, v));
    return v;
  }

 public:
  // The rows up to the line that starts at byte `stop`.
  void read_rows(std::size_t stop) {
    std::string_view line;
    std::vector<std::string_view> fields;
    if (rows_ == 0) row_bytes_start_ = lines_.bytes_consumed();
    while (lines_.bytes_consumed() < stop && next_line(line)) {
      if (cancel_ && rows_ % 4096 == 0 && cancel_->load(std::memory_order_relaxed))
        throw std::runtime_error(rec_.source + ": reading cancelled");
      if (last_line_truncated_) {
        if (!trim(line).empty())
          rec_.warnings.push_back(locate(rec_.source, line_no_, 0) +
                                  ": last line has no newline (a run cut off mid-write?); "
                                  "dropped");
        break;
      }
      if (read_row_quickly(line)) continue;
      if (trim(line).empty()) continue;
      split_fields(line, fields);
      if (fields.size() != field_count_)
        fail(0,
             "expected " + std::to_string(field_count_) + " fields as in the column line " +
                 std::to_string(column_line_) + ", found " + std::to_string(fields.size()) +
                 (line.find('"') != std::string_view::npos
                      ? " (a quoted cell holds a ',': a decimal comma? standcal-recording/1 writes "
                        "'.' as the decimal point and no ',' inside a cell)"
                      : ""));
      const RecordingSample sample = parse_row(fields);
      if (first_row_) first_ = sample;
      check_order(sample);
      emit(sample);
      previous_ = sample;
    }
  }

 private:
  // A row read: to the sink, or kept.
  void emit(const RecordingSample& sample) {
    if (sink_) {
      sink_->row(sample);
    } else {
      rec_.samples.push_back(sample);
    }
    if (++rows_ == kRowsToSizeFrom) announce_size();
  }

  // The quick path of a row, for the rows of a dwell as the writers write them: one pass
  // over the bytes that parses each number as it finds its end (no field list, no second
  // walk), and passes over a still run whose text repeats with one comparison. Half of
  // `fit`'s reading went to splitting the row and parsing the fields again
  // (docs/performance.md). A row it does not expect -- the first, a changed still column,
  // a quote or a space in a number or still column (a column the reader does not know is
  // passed over unread, as the general path ignores it), an empty or exponent number,
  // another field count, time going backwards, a blank line -- it leaves alone (false),
  // and the general path reads it or says what is wrong with it, as before.
  enum class QuickStep : std::uint8_t { skip, number, still_run };
  struct QuickField {
    QuickStep step = QuickStep::skip;
    std::uint8_t slot = 0;  // number: kQuickT...kQuickTemp; still_run: index in still_runs_
  };
  static constexpr std::array<Column, 5> kQuickColumns{kT, kFx, kFy, kFz, kTemp};  // by slot
  static constexpr std::uint8_t kQuickT = 0, kQuickTemp = 4;

  void plan_quick_rows() {
    quick_fields_.assign(field_count_, QuickField{});
    for (std::size_t slot = 0; slot < kQuickColumns.size(); ++slot)
      if (index_[kQuickColumns[slot]] >= 0)
        quick_fields_[static_cast<std::size_t>(index_[kQuickColumns[slot]])] = {
            QuickStep::number, static_cast<std::uint8_t>(slot)};
    for (std::size_t r = 0; r < still_runs_.size(); ++r)
      quick_fields_[still_runs_[r].first] = {QuickStep::still_run, static_cast<std::uint8_t>(r)};
  }

  bool read_row_quickly(std::string_view line) {
    if (first_row_) return false;
    const char* p = line.data();
    const char* const end = p + line.size();
    std::array<double, 5> numbers{kNoValue, kNoValue, kNoValue, kNoValue, kNoValue};
    for (std::size_t field = 0; field < quick_fields_.size();) {
      const QuickField& q = quick_fields_[field];
      if (q.step == QuickStep::number) {
        if (!scan_plain_decimal(p, end, numbers[q.slot])) return false;
        ++field;
      } else if (q.step == QuickStep::still_run) {
        const StillRun& run = still_runs_[q.slot];
        if (static_cast<std::size_t>(end - p) < run.text.size() ||
            std::memcmp(p, run.text.data(), run.text.size()) != 0)
          return false;
        p += run.text.size();  // the same bytes hold the same commas: the same fields
        field = run.last + 1;
      } else {
        while (p != end && *p != ',') ++p;
        ++field;
      }
      if (field == quick_fields_.size()) {
        if (p != end) return false;  // more fields than the column line's
      } else {
        if (p == end || *p != ',') return false;  // fewer, or a number that goes on
        ++p;
      }
    }
    // The still columns repeat, so position and commanded angles do: of check_order's rules
    // only time's order is left.
    if (numbers[kQuickT] < previous_.t_s) return false;
    for (std::size_t slot = 0; slot < kQuickColumns.size(); ++slot)  // parse_row names the field
      if (index_[kQuickColumns[slot]] >= 0 && !within_column(kQuickColumns[slot], numbers[slot]))
        return false;
    previous_.t_s = numbers[kQuickT];
    previous_.f_mps2 = Vec3(numbers[1], numbers[2], numbers[3]);
    previous_.temp_c = numbers[kQuickTemp];
    emit(previous_);
    return true;
  }

  // Columns that hold still through a dwell (position, angles, mount, arrival, approach)
  // repeat their text row after row, and the same text is the same value: each is parsed
  // when its text changes, which halves the numbers a stand recording's rows need parsed.
  // Adjacent still columns are compared as one span of the line (standcal writes two such
  // runs), since a comparison per column cost a tenth of the reading (docs/performance.md).
  struct StillRun {
    std::size_t first = 0;  // field indices, inclusive
    std::size_t last = 0;
    std::vector<Column> columns;
    std::string text;  // the span in the previous row
  };

  void find_still_runs() {
    static constexpr std::array<Column, 8> kStill{kPos, kA1Cmd,    kA2Cmd,   kA1,
                                                  kA2,  kMountCol, kTArrive, kApproach};
    std::vector<std::pair<std::size_t, Column>> present;
    for (Column c : kStill)
      if (index_[c] >= 0) present.emplace_back(static_cast<std::size_t>(index_[c]), c);
    std::sort(present.begin(), present.end());
    for (const auto& [field, column] : present) {
      if (still_runs_.empty() || field != still_runs_.back().last + 1)
        still_runs_.push_back({field, field, {}, {}});
      still_runs_.back().last = field;
      still_runs_.back().columns.push_back(column);
    }
  }

  // Marks in changed_ the still columns whose text differs from the previous row's.
  void find_changed_columns(const std::vector<std::string_view>& f) {
    changed_.fill(false);
    for (StillRun& run : still_runs_) {
      const char* begin = f[run.first].data();
      const std::string_view span(
          begin, static_cast<std::size_t>(f[run.last].data() + f[run.last].size() - begin));
      if (!first_row_ && span == run.text) continue;
      run.text.assign(span);
      for (Column c : run.columns) changed_[static_cast<std::size_t>(c)] = true;
    }
  }
  bool repeats(Column c) const { return !changed_[static_cast<std::size_t>(c)]; }

  // After the first rows, the samples vector is sized for the rest of the file at their
  // mean length: growing it by doubling copied it and held old and new at once (1.5-2x
  // the recording's memory at the peak).
  static constexpr std::size_t kRowsToSizeFrom = 256;
  // (A sink is told the same estimate: reserved memory costs nothing until it is used.)
  void announce_size() {
    if (lines_.bytes_total() <= lines_.bytes_consumed()) return;
    const double bytes_per_row = static_cast<double>(lines_.bytes_consumed() - row_bytes_start_) /
                                 static_cast<double>(kRowsToSizeFrom);
    const double remaining = static_cast<double>(lines_.bytes_total() - lines_.bytes_consumed());
    const std::size_t rows =
        kRowsToSizeFrom + static_cast<std::size_t>(remaining / bytes_per_row * 1.02) + 16;
    if (sink_)
      sink_->expect_rows(rows);
    else
      rec_.samples.reserve(rows);
  }

  RecordingSample parse_row(const std::vector<std::string_view>& f) {
    RecordingSample s = previous_;  // the still columns' values, where their text repeats
    find_changed_columns(f);
    s.t_s = number(f, kT, false);
    if (!repeats(kPos)) {
      const int pos_col = index_[kPos];
      if (!parse_int(f[static_cast<std::size_t>(pos_col)], s.pos) || s.pos < 0)
        fail(pos_col + 1, "column 'pos': '" + std::string(f[static_cast<std::size_t>(pos_col)]) +
                              "' is not a position index (an integer >= 0)");
    }
    if (!repeats(kA1Cmd)) s.alpha1_cmd_deg = number(f, kA1Cmd, false);
    if (!repeats(kA2Cmd)) s.alpha2_cmd_deg = number(f, kA2Cmd, false);
    if (!repeats(kA1)) s.alpha1_deg = number(f, kA1, true);
    if (!repeats(kA2)) s.alpha2_deg = number(f, kA2, true);
    s.f_mps2 = Vec3(number(f, kFx, false), number(f, kFy, false), number(f, kFz, false));
    s.temp_c = number(f, kTemp, true);
    if (!repeats(kTArrive)) s.t_arrive_s = number(f, kTArrive, true);
    if (!repeats(kMountCol)) parse_mount_field(f, s);
    if (!repeats(kApproach)) parse_approach_field(f, s);
    return s;
  }

  void parse_mount_field(const std::vector<std::string_view>& f, RecordingSample& s) const {
    const int i = index_[kMountCol];
    if (i < 0) return;
    const std::string text(unquoted(f[static_cast<std::size_t>(i)]));
    s.mount.reset();
    if (text.empty()) return;
    Mount m{};
    if (!parse_mount(text, m)) fail(i + 1, "column 'mount': '" + text + "' is not x, y or z");
    s.mount = m;
  }

  void parse_approach_field(const std::vector<std::string_view>& f, RecordingSample& s) const {
    const int i = index_[kApproach];
    s.approach = 0;
    if (i < 0 || trim(f[static_cast<std::size_t>(i)]).empty()) return;
    int a = 0;
    if (!parse_int(f[static_cast<std::size_t>(i)], a) || (a != 1 && a != -1))
      fail(i + 1, "column 'approach': '" + std::string(f[static_cast<std::size_t>(i)]) +
                      "' must be +1 or -1");
    s.approach = static_cast<std::int8_t>(a);
  }

  void check_order(const RecordingSample& s) {
    if (!first_row_) {
      const RecordingSample& prev = previous_;
      if (s.t_s < prev.t_s)
        fail(index_[kT] + 1, "t_s goes backwards (" + round_trip_text(s.t_s) + " after " +
                                 round_trip_text(prev.t_s) + "); times must not decrease");
      if (s.pos == prev.pos) {
        if (s.alpha1_cmd_deg != prev.alpha1_cmd_deg || s.alpha2_cmd_deg != prev.alpha2_cmd_deg)
          fail(index_[kA1Cmd] + 1, "commanded angles change inside position " +
                                       std::to_string(s.pos) + " (a new position needs a new pos)");
        return;
      }
    }
    first_row_ = false;
    if (!finished_positions_.insert(s.pos).second)
      fail(index_[kPos] + 1, "position " + std::to_string(s.pos) +
                                 " appears again after other positions: the rows of one "
                                 "position must be contiguous (a repeat needs a new pos index)");
  }

  double header_number(const std::string& key, const std::string& value) const {
    double v = 0;
    if (!parse_double(value, v))
      throw RecordingError(rec_.source, header_lines_.at(key), 0,
                           "header '" + key + "': '" + value + "' is not a number");
    return v;
  }

  [[noreturn]] void refuse_header(const std::string& key, const std::string& why) const {
    throw RecordingError(rec_.source, header_lines_.at(key), 0, "header '" + key + "': " + why);
  }

  void finish_header() {
    const std::string format = rec_.header_value("format");
    if (!seen_keys_.count("format"))
      throw RecordingError(
          rec_.source, 1, 0,
          "required header '# format: " + std::string(kRecordingFormat) + "' is missing");
    if (format != kRecordingFormat)
      throw RecordingError(rec_.source, header_lines_.at("format"), 0,
                           "unsupported format '" + format + "' (this reader reads " +
                               std::string(kRecordingFormat) + ")");
    for (const auto& [key, value] : rec_.header) apply_known_key(key, value);
    check_unit_wander();
  }

  // The run's unit wander (RecordedUnitWander): a range needs its lower end, and runs upwards.
  void check_unit_wander() const {
    const RecordedUnitWander& w = rec_.unit_wander;
    if (w.tau_max_s > 0 && w.tau_s == 0)
      refuse_header(kHeaderUnitWanderTauMaxS,
                    std::string("a range needs its lower end too: ") + kHeaderUnitWanderTauS);
    if (w.tau_max_s > 0 && w.tau_max_s < w.tau_s)
      refuse_header(kHeaderUnitWanderTauMaxS,
                    round_trip_text(w.tau_max_s) + " s is below " + kHeaderUnitWanderTauS + " " +
                        round_trip_text(w.tau_s) + " s: the range is MIN to MAX");
    check_unit_wander_axes();
  }

  // Each axis's size: all three or none, beside the size that is their largest.
  void check_unit_wander_axes() const {
    std::vector<std::string> given;
    for (const char* key : kHeaderUnitWanderAxisUg)
      if (seen_keys_.count(key)) given.emplace_back(key);
    if (given.empty()) return;
    if (given.size() < 3)
      refuse_header(given.front(), "each axis's size comes with the others': " +
                                       std::string(kHeaderUnitWanderAxisUg[0]) +
                                       ", _y_ug and _z_ug");
    const RecordedUnitWander& w = rec_.unit_wander;
    if (!seen_keys_.count(kHeaderUnitWanderUg))
      refuse_header(given.front(), std::string("the axes' sizes come beside ") +
                                       kHeaderUnitWanderUg + ", their largest");
    if (w.size_axes_ug.maxCoeff() != w.size_ug)
      refuse_header(given.front(), "the largest axis's size, " +
                                       round_trip_text(w.size_axes_ug.maxCoeff()) + " ug, is not " +
                                       kHeaderUnitWanderUg + "'s " + round_trip_text(w.size_ug) +
                                       " ug: that key holds the largest");
  }

  // A number of the unit's wander, within kMaxUnitWanderUg or kMin/kMaxUnitWanderTauS.
  double unit_wander_number(const std::string& key, const std::string& value, double min,
                            double max, const char* unit) const {
    const double v = header_number(key, value);
    if (!(v >= min && v <= max))
      refuse_header(key, value + " " + unit + " is outside " + plain_round_trip_text(min) +
                             " ... " + plain_round_trip_text(max) + " " + unit);
    return v;
  }

  void apply_known_key(const std::string& key, const std::string& value) {
    if (key == "g_local_mps2") {
      rec_.g_local_mps2 = header_number(key, value);
      rec_.g_from_header = true;
      if (rec_.g_local_mps2 < 9.7 || rec_.g_local_mps2 > 9.9)
        refuse_header(key, value + " m/s^2 is not a plausible local gravity (9.7 ... 9.9)");
    } else if (key == "settle_s") {
      rec_.settle_s = header_number(key, value);
      if (!(rec_.settle_s >= 0 && rec_.settle_s <= kMaxAbsTime_s))
        refuse_header(key, value + " s is not a settling time (0 ... 1e12 s)");
    } else if (key == kHeaderWarmupS) {
      rec_.warmup_s = header_number(key, value);
      if (!(rec_.warmup_s >= 0 && rec_.warmup_s <= kMaxAbsTime_s))
        refuse_header(key, value + " s is not a warm-up time (0 ... 1e12 s)");
    } else if (key == "sample_rate_hz") {
      rec_.sample_rate_hz = header_number(key, value);
      if (!is_plausible_sample_rate(rec_.sample_rate_hz))
        refuse_header(key, implausible_sample_rate_text(value));
    } else if (key == "temp_ref_c") {
      rec_.temp_ref_c = header_number(key, value);
      if (!is_plausible_temperature(*rec_.temp_ref_c))
        refuse_header(key,
                      value + " degC is not a temperature a unit works at (-273.15 ... 1000 degC)");
    } else if (key == kHeaderUnitWanderUg) {
      rec_.unit_wander.size_ug = unit_wander_number(key, value, 0, kMaxUnitWanderUg, "ug");
    } else if (const auto axis =
                   std::find(kHeaderUnitWanderAxisUg.begin(), kHeaderUnitWanderAxisUg.end(), key);
               axis != kHeaderUnitWanderAxisUg.end()) {
      rec_.unit_wander.size_axes_ug[axis - kHeaderUnitWanderAxisUg.begin()] =
          unit_wander_number(key, value, 0, kMaxUnitWanderUg, "ug");
    } else if (key == kHeaderUnitWanderTauS) {
      rec_.unit_wander.tau_s =
          unit_wander_number(key, value, kMinUnitWanderTauS, kMaxUnitWanderTauS, "s");
    } else if (key == kHeaderUnitWanderTauMaxS) {
      rec_.unit_wander.tau_max_s =
          unit_wander_number(key, value, kMinUnitWanderTauS, kMaxUnitWanderTauS, "s");
    } else if (key == kHeaderUnitStaticTauFloorS) {
      rec_.unit_static_tau_floor_s =
          unit_wander_number(key, value, kMinUnitWanderTauS, kMaxUnitWanderTauS, "s");
    } else if (key == kHeaderUnitStaticCurves) {
      if (const std::string why = wander_curves_text_error(value); !why.empty())
        refuse_header(key, "not the Allan curves of a static recording: " + why);
    } else if (key == "unit_serial") {
      rec_.unit_serial = value;
    } else if (key == "program") {
      rec_.program = value;
    } else if (key == "mount") {
      Mount m{};
      if (!parse_mount(value, m))
        throw RecordingError(rec_.source, header_lines_.at(key), 0,
                             "header 'mount': '" + value + "' is not x, y or z");
      rec_.default_mount = m;
    }
  }

  LineSource& lines_;
  RecordingRowSink* sink_;                     // null: the rows go into rec_.samples
  const std::atomic<bool>* cancel_ = nullptr;  // set: stop reading when it turns true
  RecordingSample first_;
  RecordingSample previous_;
  std::vector<StillRun> still_runs_;
  std::vector<QuickField> quick_fields_;      // per field of the column line
  std::array<bool, kColumnKinds> changed_{};  // per row: the still columns to parse
  std::size_t row_bytes_start_ = 0;           // input bytes before the first row
  std::size_t rows_ = 0;                      // rows read so far
  int line_no_ = 0;
  int column_line_ = 0;
  bool last_line_truncated_ = false;
  bool first_row_ = true;
  std::size_t field_count_ = 0;
  std::array<int, kColumnKinds> index_{};
  std::unordered_set<std::string> seen_keys_;
  std::map<std::string, int> header_lines_;
  std::unordered_set<int> finished_positions_;
  Recording rec_;
};

void append_number(std::string& out, double v, int decimals) {
  if (std::isnan(v)) return;  // empty field
  std::array<char, 64> buf{};
  const auto [end, ec] =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, decimals);
  if (ec == std::errc()) out.append(buf.data(), end);
}

}  // namespace

RecordingError::RecordingError(const std::string& source, int line, int column,
                               const std::string& what)
    : std::runtime_error(locate(source, line, column) + ": " + what),
      source_(source),
      line_(line),
      column_(column) {}

double warmup_end_s(const Recording& rec) {
  if (rec.warmup_s > 0)
    for (const RecordingSample& s : rec.samples)
      if (s.pos == 0) return s.t_s + rec.warmup_s;
  return -std::numeric_limits<double>::infinity();
}

std::string Recording::header_value(std::string_view key) const {
  for (const auto& [k, v] : header)
    if (k == key) return v;
  return {};
}

void Recording::set_header(const std::string& key, const std::string& value) {
  for (auto& [k, v] : header)
    if (k == key) {
      v = value;
      return;
    }
  header.emplace_back(key, value);
}

bool is_plausible_accelerometer_value(double v) { return std::abs(v) <= kMaxAbsAccelerometerValue; }

// Each value said with the digits that show it past its bound (1000000000000.5, not 1e+12,
// beyond 1e12).
std::string implausible_accelerometer_value_text(double v) {
  return number_texts_apart(v, kMaxAbsAccelerometerValue).value +
         " is beyond any accelerometer's output (at most 1e12 in counts, g or m/s^2): a corrupted "
         "value?";
}

bool is_plausible_time(double t_s) { return std::abs(t_s) <= kMaxAbsTime_s; }

std::string implausible_time_text(double t_s) {
  return number_texts_apart(t_s, kMaxAbsTime_s).value +
         " s is not a time a recording holds (within +-1e12 s): a corrupted value?";
}

bool is_plausible_sample_rate(double rate_hz) {
  return rate_hz >= kMinSampleRate_hz && rate_hz <= kMaxSampleRate_hz * (1 + 1e-6);
}

std::string implausible_sample_rate_text(const std::string& rate_as_written) {
  return rate_as_written + " Hz is not a sample rate (at least 1e-12, at most 1e6 Hz)";
}

bool is_plausible_temperature(double temp_c) {
  return temp_c >= kLowestTemperature_c && temp_c <= kHighestTemperature_c;
}

double temperature_bound_past_c(double temp_c) {
  return temp_c < kLowestTemperature_c ? kLowestTemperature_c : kHighestTemperature_c;
}

std::string implausible_temperature_text(double temp_c) {
  return number_texts_apart(temp_c, temperature_bound_past_c(temp_c)).value +
         " degC is not a unit's temperature (-273.15 ... 1000 degC): a corrupted value?";
}

std::string implausible_sample_text(const RecordingSample& s) {
  const std::array<std::pair<Column, double>, 10> numbers{{{kT, s.t_s},
                                                           {kA1Cmd, s.alpha1_cmd_deg},
                                                           {kA2Cmd, s.alpha2_cmd_deg},
                                                           {kA1, s.alpha1_deg},
                                                           {kA2, s.alpha2_deg},
                                                           {kFx, s.f_mps2.x()},
                                                           {kFy, s.f_mps2.y()},
                                                           {kFz, s.f_mps2.z()},
                                                           {kTemp, s.temp_c},
                                                           {kTArrive, s.t_arrive_s}}};
  for (const auto& [column, value] : numbers)
    if (!(std::isnan(value) && is_optional(column)) && !within_column(column, value))
      return "column '" + std::string(kColumnNames[column]) +
             "': " + beyond_column_text(column, value);
  return {};
}

bool is_assumed_gravity_warning(std::string_view warning) {
  return warning.find("assuming standard gravity") != std::string_view::npos;
}

std::string g_option_replaces_header_warning(const std::string& source, double given_mps2,
                                             double header_mps2, std::string_view option) {
  char ppm[32];
  std::snprintf(ppm, sizeof ppm, "%+.1f ppm", (given_mps2 / header_mps2 - 1) * 1e6);
  return source + ": " + std::string(option) + " " + round_trip_text(given_mps2) +
         " replaces the header's g_local_mps2 " + round_trip_text(header_mps2) + " (" + ppm +
         "): the scale factors take up the difference";
}

void Recording::use_given_g(double g_mps2, std::string_view option) {
  // The operator's word over the header's (a g measured since), but said: it moves every
  // scale factor by the difference.
  if (g_from_header && g_mps2 != g_local_mps2)
    warnings.push_back(g_option_replaces_header_warning(source, g_mps2, g_local_mps2, option));
  g_local_mps2 = g_mps2;
  g_from_header = true;  // given, not assumed
  std::erase_if(warnings, [](const std::string& w) { return is_assumed_gravity_warning(w); });
}

void Recording::use_given_sample_rate(double rate_hz, std::string_view option) {
  if (!is_plausible_sample_rate(rate_hz))
    throw std::invalid_argument(implausible_sample_rate_text(round_trip_text(rate_hz)));
  if (!(sample_rate_hz > 0))
    sample_rate_hz = rate_hz;
  else if (rate_hz != sample_rate_hz)
    warnings.push_back(rate_option_not_used_warning(source, rate_hz, sample_rate_hz, option));
}

std::string rate_option_not_used_warning(const std::string& source, double given_hz,
                                         double header_hz, std::string_view option) {
  return source + ": " + std::string(option) + " " + round_trip_text(given_hz) +
         " is not used: the header's sample_rate_hz " + round_trip_text(header_hz) +
         " was written with the samples";
}

Recording parse_recording(std::string_view text, const std::string& source) {
  LineSource lines = LineSource::of_text(text);
  return Parser(lines, source, nullptr).run();
}

Recording read_recording(const std::string& path) {
  LineSource lines = LineSource::of_file(path);
  return Parser(lines, path, nullptr).run();
}

Recording stream_recording(const std::string& path, RecordingRowSink& sink) {
  LineSource lines = LineSource::of_file(path);
  return Parser(lines, path, &sink).run();
}

struct RecordingReader::Impl {
  explicit Impl(const std::string& path)
      : lines(LineSource::of_file(path)), parser(lines, path, nullptr) {}
  LineSource lines;
  Parser parser;
};

struct RecordingPartReader::Impl {
  Impl(const std::string& path, std::size_t begin, const Parser& head)
      : lines(LineSource::of_file(path, begin)), parser(head, lines) {}
  LineSource lines;
  Parser parser;
};

RecordingReader::RecordingReader(const std::string& path)
    : path_(path), impl_(std::make_unique<Impl>(path)) {}
RecordingReader::~RecordingReader() = default;

const Recording& RecordingReader::read_header(RecordingRowSink& sink) {
  impl_->parser.set_sink(&sink);
  return impl_->parser.read_header();
}

void RecordingReader::read_rows(RecordingRowSink& sink, std::size_t stop) {
  impl_->parser.set_sink(&sink);
  impl_->parser.read_rows(stop);
}

Recording RecordingReader::finish() { return impl_->parser.finish(); }

std::size_t RecordingReader::bytes_total() const { return impl_->lines.bytes_total(); }

std::optional<std::size_t> RecordingReader::dwell_start_after(std::size_t from,
                                                              std::size_t within) const {
  const auto pos_field = static_cast<std::size_t>(impl_->parser.pos_field());
  LineSource lines = LineSource::of_file(path_, from);
  if (lines.file_identity() != impl_->lines.file_identity()) return std::nullopt;  // replaced
  std::string_view line;
  if (!lines.next(line)) return std::nullopt;  // the rest of the line `from` falls in
  std::vector<std::string_view> fields;
  std::string previous_pos;
  bool have_previous = false;
  while (lines.bytes_consumed() <= from + within) {
    const std::size_t start = lines.bytes_consumed();
    if (!lines.next(line) || lines.unterminated()) return std::nullopt;
    split_fields(line, fields);
    const std::string_view pos = pos_field < fields.size() ? fields[pos_field] : "";
    if (have_previous && pos != previous_pos) return start;
    previous_pos.assign(pos);
    have_previous = true;
  }
  return std::nullopt;
}

RecordingPartReader RecordingReader::part_from(std::size_t begin) const {
  RecordingPartReader part;
  part.impl_ = std::make_unique<RecordingPartReader::Impl>(path_, begin, impl_->parser);
  return part;
}

bool RecordingReader::continues_with(const RecordingPartReader& part) const {
  const Parser& head = impl_->parser;
  const Parser& later = part.impl_->parser;
  if (!part.read_ || head.rows() == 0 || later.rows() == 0) return false;
  // The same file: one renamed over the path meanwhile is not this one's rest.
  if (part.impl_->lines.file_identity() != impl_->lines.file_identity()) return false;
  if (later.first_row().t_s < head.last_row().t_s) return false;
  for (const int pos : later.positions())
    if (head.positions().count(pos)) return false;  // includes the head's last position
  return true;
}

RecordingPartReader::RecordingPartReader() = default;
RecordingPartReader::RecordingPartReader(RecordingPartReader&&) noexcept = default;
RecordingPartReader::~RecordingPartReader() = default;

bool RecordingPartReader::read(RecordingRowSink& sink, const std::atomic<bool>& cancel) {
  read_ = false;
  try {
    impl_->parser.set_sink(&sink);
    impl_->parser.set_cancel(&cancel);
    impl_->parser.read_rows(kToEnd);
    read_ = impl_->parser.warnings().empty();
  } catch (...) {
    read_ = false;  // read again in order, where the error is told with its line
  }
  return read_;
}

namespace {

// A header entry is one "# key: value" line: a control character in a field's text would
// inject a header key ("AU\n# mount: y") or repeat one, and the reader refuses a recording
// with a repeated key only at the fit, after the whole run.
void check_header_entry(const std::string& key, const std::string& value) {
  if (const auto c = find_control_character(key))
    throw std::invalid_argument("recording header key '" + key + "' contains " + describe(*c));
  if (key.empty() || key.find(':') != std::string::npos || trim(key) != key)
    throw std::invalid_argument("recording header key '" + key +
                                "' must be a name without ':' or surrounding spaces");
  if (const auto c = find_control_character(value))
    throw std::invalid_argument("recording header '" + key + "': the value contains " +
                                describe(*c) +
                                "; header values must be printable text on one line");
  for (const std::string* text : {&key, &value})
    if (const auto at = first_non_utf8_byte(*text))
      throw std::invalid_argument("recording header '" + key + "': byte " +
                                  std::to_string(*at + 1) + " of the " +
                                  (text == &key ? "key" : "value") + " is not UTF-8 text");
}

}  // namespace

std::string format_recording_header(const Recording& rec) {
  std::string out = "# format: " + std::string(kRecordingFormat) + "\n";
  std::set<std::string> keys;
  for (const auto& [key, value] : rec.header) {
    if (key == "format") continue;
    check_header_entry(key, value);
    if (!keys.insert(key).second)
      throw std::invalid_argument("recording header key '" + key + "' appears twice");
    out += "# " + key + ": " + value + "\n";
  }
  out += "t_s,pos,alpha1_cmd_deg,alpha2_cmd_deg";
  if (rec.columns.alpha_measured) out += ",alpha1_deg,alpha2_deg";
  out += ",fx_mps2,fy_mps2,fz_mps2";
  if (rec.columns.temp) out += ",temp_c";
  if (rec.columns.mount) out += ",mount";
  if (rec.columns.t_arrive) out += ",t_arrive_s";
  if (rec.columns.approach) out += ",approach";
  out += "\n";
  return out;
}

void append_recording_rows(std::string& out, const RecordingColumns& columns,
                           const std::vector<RecordingSample>& samples) {
  for (const RecordingSample& s : samples) {
    append_number(out, s.t_s, 4);
    out += ',';
    out += std::to_string(s.pos);
    out += ',';
    append_number(out, s.alpha1_cmd_deg, 6);
    out += ',';
    append_number(out, s.alpha2_cmd_deg, 6);
    if (columns.alpha_measured) {
      out += ',';
      append_number(out, s.alpha1_deg, 6);
      out += ',';
      append_number(out, s.alpha2_deg, 6);
    }
    for (int i = 0; i < 3; ++i) {
      out += ',';
      append_number(out, s.f_mps2[i], 9);
    }
    if (columns.temp) {
      out += ',';
      append_number(out, s.temp_c, 3);
    }
    if (columns.mount) {
      out += ',';
      if (s.mount) out += mount_name(*s.mount);
    }
    if (columns.t_arrive) {
      out += ',';
      append_number(out, s.t_arrive_s, 4);
    }
    if (columns.approach) {
      out += ',';
      if (s.approach != 0) out += s.approach > 0 ? "1" : "-1";
    }
    out += '\n';
  }
}

void write_recording(const Recording& rec, const std::string& path) {
  std::string text = format_recording_header(rec);
  text.reserve(text.size() + rec.samples.size() * 110);
  append_recording_rows(text, rec.columns, rec.samples);
  // -o /dev/null or /dev/stdout is written in place (atomic_file.hpp).
  write_file_atomically(path, text, "the recording");
}

}  // namespace standcal
