#include "drivers/socketcan/dbc.hpp"

#include <charconv>
#include <cstdint>
#include <regex>
#include <set>

namespace standcal::drivers::can {
namespace {

// BO_ ids with this bit are 29-bit (extended) identifiers.
constexpr std::uint64_t kDbcExtendedFlag = 0x80000000ULL;
// Longest BO_ / SG_ / SIG_VALTYPE_ line read.
constexpr std::size_t kMaxStatementChars = 4096;
// Vector's pseudo-message that holds signals attached to no frame.
constexpr std::uint64_t kIndependentSignalsId = 0xC0000000ULL;

Status dbc_error(const std::string& source, int line, const std::string& what) {
  return Status::error(ErrorKind::invalid_argument,
                       source + (line > 0 ? ":" + std::to_string(line) : "") + ": " + what);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

bool parse_int(const std::string& text, long long lo, long long hi, long long& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc{} && end == text.data() + text.size() && out >= lo && out <= hi;
}

bool parse_double(std::string text, double& out) {
  if (!text.empty() && text.front() == '+') text.erase(0, 1);  // from_chars takes no '+'
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc{} && end == text.data() + text.size();
}

// DBC units as tools write them (UTF-8 or the Windows-1252 that CANdb++ saves) to the
// spellings the layout knows.
std::string normalised_unit(const std::string& unit) {
  static const std::map<std::string, std::string> kSpellings{{"\xC2\xB0"
                                                              "C",
                                                              "degC"},
                                                             {"\xB0"
                                                              "C",
                                                              "degC"},
                                                             {"deg C", "degC"},
                                                             {"Celsius", "degC"},
                                                             {"m/s^2", "m/s2"},
                                                             {"m/s\xC2\xB2", "m/s2"},
                                                             {"m/s\xB2", "m/s2"},
                                                             {"m/s/s", "m/s2"},
                                                             {"\xC2\xB5g", "ug"},
                                                             {"\xB5g", "ug"},
                                                             {"\xCE\xBCg", "ug"}};
  const auto it = kSpellings.find(unit);
  return it == kSpellings.end() ? unit : it->second;
}

// Quotes that open or close a string on this line (a DBC string escapes '"' as '\"').
bool toggles_string(std::string_view line, bool in_string) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '\\' && in_string) {
      ++i;
      continue;
    }
    if (line[i] == '"') in_string = !in_string;
  }
  return in_string;
}

// The line starts with this keyword as a word of its own (not BO_TX_BU_, SG_MUL_VAL_).
bool is_statement(std::string_view line, std::string_view keyword) {
  return line.size() > keyword.size() && line.substr(0, keyword.size()) == keyword &&
         (line[keyword.size()] == ' ' || line[keyword.size()] == '\t');
}

struct Message {
  std::string name;
  std::uint32_t id = 0;
  bool extended = false;
  int dlc = 0;
  bool independent = false;
};

class DbcParser {
 public:
  explicit DbcParser(std::string source) : source_(std::move(source)) {}

  Result<std::vector<DbcSignal>> parse(std::string_view text) {
    bool in_string = false;
    int line_no = 0, string_opened = 0;
    while (!text.empty()) {
      const std::size_t eol = text.find('\n');
      const std::string_view line = text.substr(0, eol);
      text.remove_prefix(eol == std::string_view::npos ? text.size() : eol + 1);
      ++line_no;
      // A comment or attribute string may run over lines; nothing inside it is a keyword.
      if (!in_string) {
        if (Status s = statement(trim(line), line_no); !s) return s;
      }
      const bool was_in_string = in_string;
      in_string = toggles_string(line, in_string);
      if (in_string && !was_in_string) string_opened = line_no;
    }
    // Else everything after the quote would be skipped without a word.
    if (in_string) return dbc_error(source_, string_opened, "a string opened here is never closed");
    for (auto& s : signals_)
      if (floats_.count({s.spec.can_id | (s.spec.extended ? kDbcExtendedFlag : 0), s.spec.name}))
        s.is_float = true;
    return signals_;
  }

 private:
  Status statement(std::string_view line, int line_no) {
    using Reader = Status (DbcParser::*)(const std::string&, int);
    const Reader read = is_statement(line, "BO_")            ? &DbcParser::message
                        : is_statement(line, "SG_")          ? &DbcParser::signal
                        : is_statement(line, "SIG_VALTYPE_") ? &DbcParser::value_type
                                                             : nullptr;
    if (read == nullptr) {
      // Any other statement ends the message's signal list.
      if (!line.empty()) in_message_ = false;
      return Status::ok();
    }
    // std::regex recurses per character: a bounded line keeps a hostile file from
    // exhausting the stack (real BO_ and SG_ lines are well under a hundred characters
    // plus their receivers).
    if (line.size() > kMaxStatementChars)
      return dbc_error(source_, line_no,
                       "line is " + std::to_string(line.size()) + " characters long; a " +
                           std::string(line.substr(0, line.find(' '))) + " line may have at most " +
                           std::to_string(kMaxStatementChars));
    return (this->*read)(std::string(line), line_no);
  }

  Status message(const std::string& line, int line_no) {
    static const std::regex kBo(R"(^BO_\s+(\d+)\s+([A-Za-z_]\w*)\s*:\s*(\d+)(\s+\S+)?\s*$)");
    std::smatch m;
    long long id = 0, dlc = 0;
    if (!std::regex_match(line, m, kBo))
      return dbc_error(source_, line_no,
                       "a BO_ line must read 'BO_ ID NAME: DLC SENDER', got '" + line + "'");
    if (!parse_int(m[1], 0, 0xFFFFFFFFLL, id))
      return dbc_error(source_, line_no, "message id " + m[1].str() + " is not a 32-bit number");
    if (!parse_int(m[3], 0, 64, dlc))
      return dbc_error(source_, line_no,
                       "message " + m[2].str() + ": DLC " + m[3].str() + " is not 0..64 bytes");
    const auto raw = static_cast<std::uint64_t>(id);
    message_ = {m[2], static_cast<std::uint32_t>(raw & 0x1FFFFFFFULL),
                (raw & kDbcExtendedFlag) != 0, static_cast<int>(dlc), raw == kIndependentSignalsId};
    in_message_ = true;
    return Status::ok();
  }

  Status signal(const std::string& line, int line_no) {
    static const std::regex kSg(
        R"re(^SG_\s+([A-Za-z_]\w*)\s*(M|m\d+M?)?\s*:\s*(\d+)\s*\|\s*(\d+)\s*@\s*([01])\s*([+-])\s*)re"
        R"re(\(\s*([^,\s]+)\s*,\s*([^)\s]+)\s*\)\s*\[\s*([^|\]]*)\|([^\]]*)\]\s*"([^"]*)"(\s.*)?$)re");
    if (!in_message_)
      return dbc_error(source_, line_no, "an SG_ line outside a BO_ message's signal list");
    std::smatch m;
    if (!std::regex_match(line, m, kSg))
      return dbc_error(source_, line_no,
                       "an SG_ line must read 'SG_ NAME : START|LENGTH@ORDER+/- (SCALE,OFFSET) "
                       "[MIN|MAX] \"UNIT\" RECEIVERS', got '" +
                           line + "'");
    if (message_.independent) return Status::ok();  // belongs to no frame
    DbcSignal s;
    s.message = message_.name;
    s.message_dlc = message_.dlc;
    s.line = line_no;
    s.multiplexed = m[2].matched;
    SignalSpec& spec = s.spec;
    spec.name = m[1];
    spec.can_id = message_.id;
    spec.extended = message_.extended;
    long long start = 0, length = 0;
    if (!parse_int(m[3], 0, 511, start) || !parse_int(m[4], 1, 64, length))
      return dbc_error(source_, line_no,
                       "signal " + spec.name + ": start bit " + m[3].str() +
                           " (0..511) or length " + m[4].str() + " (1..64 bits) out of range");
    spec.start_bit = static_cast<int>(start);
    spec.length = static_cast<int>(length);
    spec.byte_order = m[5] == "1" ? ByteOrder::intel : ByteOrder::motorola;
    spec.is_signed = m[6] == "-";
    if (!parse_double(m[7], spec.scale) || !parse_double(m[8], spec.offset))
      return dbc_error(source_, line_no,
                       "signal " + spec.name + ": scale '" + m[7].str() + "' or offset '" +
                           m[8].str() + "' is not a number");
    spec.unit = normalised_unit(std::string(trim(m[11].str())));
    signals_.push_back(std::move(s));
    return Status::ok();
  }

  // SIG_VALTYPE_ ID NAME : 1|2 ;  (IEEE float or double: not an integer field)
  Status value_type(const std::string& line, int line_no) {
    static const std::regex kVt(
        R"(^SIG_VALTYPE_\s+(\d+)\s+([A-Za-z_]\w*)\s*:?\s*([0-3])\s*;?\s*$)");
    std::smatch m;
    long long id = 0;
    if (!std::regex_match(line, m, kVt) || !parse_int(m[1], 0, 0xFFFFFFFFLL, id))
      return dbc_error(source_, line_no,
                       "a SIG_VALTYPE_ line must read 'SIG_VALTYPE_ ID NAME : N;'");
    if (m[3] == "1" || m[3] == "2") {
      const auto raw = static_cast<std::uint64_t>(id);
      floats_.insert({(raw & 0x1FFFFFFFULL) | (raw & kDbcExtendedFlag), m[2]});
    }
    in_message_ = false;
    return Status::ok();
  }

  std::string source_;
  Message message_;
  bool in_message_ = false;
  std::vector<DbcSignal> signals_;
  std::set<std::pair<std::uint64_t, std::string>> floats_;  // (id | extended flag, signal)
};

bool role_by_name(const std::string& name, SignalRole& role) {
  if (parse_role(name, role)) return true;
  if (name.rfind("counter_", 0) == 0) {
    role = SignalRole::counter;
    return true;
  }
  return false;
}

// The role `roles` gives this signal (MESSAGE.SIGNAL first, then SIGNAL); false: none.
bool role_of(const DbcSignal& s, const DbcRoles& roles, SignalRole& role) {
  if (roles.empty()) return role_by_name(s.spec.name, role);
  auto it = roles.find(s.message + "." + s.spec.name);
  if (it == roles.end()) it = roles.find(s.spec.name);
  if (it == roles.end()) return false;
  role = it->second;
  return true;
}

// Every key of `roles` names one signal: a typo must not silently drop a role, and a
// bare name that repeats across messages must say which message.
Status check_role_names(const std::vector<DbcSignal>& signals, const DbcRoles& roles,
                        const std::string& source) {
  for (const auto& [key, role] : roles) {
    std::vector<std::string> messages;
    for (const auto& s : signals)
      if (key == s.spec.name || key == s.message + "." + s.spec.name) messages.push_back(s.message);
    if (messages.empty()) return dbc_error(source, 0, "roles: no signal '" + key + "' in the file");
    if (messages.size() > 1 && messages[0] == messages[1])
      return dbc_error(source, 0, "roles: '" + key + "' is twice in message " + messages[0]);
    if (messages.size() > 1)
      return dbc_error(source, 0,
                       "roles: '" + key + "' is a signal of " + messages[0] + " and " +
                           messages[1] + "; name it MESSAGE.SIGNAL");
  }
  return Status::ok();
}

Status check_usable(const DbcSignal& s, const std::string& source) {
  const std::string where = "signal " + s.spec.name + " of " + s.message;
  if (s.multiplexed)
    return dbc_error(source, s.line, where + " is multiplexed; standcal reads only plain signals");
  if (s.is_float)
    return dbc_error(source, s.line,
                     where + " is an IEEE float (SIG_VALTYPE_); standcal reads integer signals");
  const int needed = bytes_needed(s.spec.start_bit, s.spec.length, s.spec.byte_order);
  if (needed > s.message_dlc)
    return dbc_error(source, s.line,
                     where + " needs " + std::to_string(needed) +
                         " bytes but the message's DLC is " + std::to_string(s.message_dlc));
  return Status::ok();
}

}  // namespace

Result<std::vector<DbcSignal>> parse_dbc(std::string_view text, const std::string& source) {
  return DbcParser(source).parse(text);
}

Result<FrameLayout> layout_from_dbc(std::string_view text, const std::string& source,
                                    const DbcRoles& roles) {
  auto parsed = parse_dbc(text, source);
  if (!parsed) return parsed.status();
  if (Status s = check_role_names(parsed.value(), roles, source); !s) return s;
  std::vector<SignalSpec> specs;
  for (const auto& s : parsed.value()) {
    SignalRole role{};
    if (!role_of(s, roles, role)) continue;
    if (Status usable = check_usable(s, source); !usable) return usable;
    specs.push_back(s.spec);
    specs.back().role = role;
  }
  if (specs.empty())
    return dbc_error(source, 0,
                     "no signal has a role: name the signals force_x, force_y, force_z, "
                     "temperature and counter_*, or give a JSON layout with \"dbc\" and "
                     "\"roles\" (docs/unit-can.md)");
  auto layout = FrameLayout::from_signals(std::move(specs));
  if (!layout) return Status::error(layout.status().kind, source + ": " + layout.status().message);
  return layout;
}

}  // namespace standcal::drivers::can
