// The typed protocol (protocol/jsonrpc/messages.hpp) against docs/protocol.md: each method's
// parameters as its heading lists them, each result's keys as its examples show them
// (nested objects too, where an example shows one whole), each event's keys as the events
// table lists them; and the types' JSON read back as written.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/messages.hpp"

namespace standcal::protocol {
namespace {

using nlohmann::json;
using Keys = std::set<std::string>;

std::string protocol_doc() {
  std::ifstream in(std::string(STANDCAL_SOURCE_DIR) + "/docs/protocol.md");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The section of one method: from its "### `name` " heading to the next heading.
std::string method_section(const std::string& doc, const std::string& method) {
  const std::string heading = "\n### `" + method + "` ";
  const auto start = doc.find(heading);
  if (start == std::string::npos) return {};
  const auto end = doc.find("\n#", start + heading.size());
  return doc.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

// An object written in the docs, possibly with "…" for what it leaves out: its top-level
// members as key → the text of the value. `complete` is false when the object itself
// leaves members out.
struct DocObject {
  std::map<std::string, std::string> members;
  bool complete = true;
};

// The end of the value at `i`: the ',' after it, or the '}' or ']' that closes what holds it.
std::size_t end_of_value(const std::string& text, std::size_t i) {
  int depth = 0;
  bool in_string = false;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    if (c == '{' || c == '[') ++depth;
    if (c == '}' || c == ']') {
      if (depth == 0) return i;
      --depth;
    }
    if (c == ',' && depth == 0) return i;
  }
  return i;
}

// The '}' that closes the object `text` starts with: its members' values skipped one by one.
std::size_t closing_brace(const std::string& text) {
  std::size_t i = 1;
  while ((i = end_of_value(text, i)) < text.size() && text[i] == ',') ++i;
  return i;
}

DocObject parse_doc_object(const std::string& text) {  // text starts at '{'
  DocObject o;
  const std::size_t close = closing_brace(text);
  const std::string body = text.substr(1, close - 1);
  std::size_t i = 0;
  while (i < body.size()) {
    while (i < body.size() && (std::isspace(static_cast<unsigned char>(body[i])) || body[i] == ','))
      ++i;
    if (i >= body.size()) break;
    if (body[i] != '"') {  // "…" standing for members left out
      o.complete = false;
      i = end_of_value(body, i);
      continue;
    }
    const auto key_end = body.find('"', i + 1);
    const std::string key = body.substr(i + 1, key_end - i - 1);
    auto colon = body.find_first_not_of(" \n", key_end + 1);
    if (colon == std::string::npos || body[colon] != ':') {  // ["a","b"]-style list of names
      o.complete = false;
      i = end_of_value(body, key_end + 1);
      continue;
    }
    const auto value_start = body.find_first_not_of(" \n", colon + 1);
    const auto value_end = end_of_value(body, value_start);
    o.members[key] = body.substr(value_start, value_end - value_start);
    i = value_end;
  }
  return o;
}

// Compares a documented object with the JSON of a type, recursively where the docs show a
// nested object whole; failures name the path.
void expect_same_keys(const std::string& doc_text, const json& typed, const std::string& path) {
  const DocObject doc = parse_doc_object(doc_text);
  Keys doc_keys, type_keys;
  for (const auto& [k, v] : doc.members) doc_keys.insert(k);
  for (const auto& [k, v] : typed.items()) type_keys.insert(k);
  if (doc.complete) {
    EXPECT_EQ(doc_keys, type_keys) << path << ": the docs' keys and the type's differ";
  } else {
    for (const std::string& k : doc_keys)
      EXPECT_TRUE(type_keys.count(k))
          << path << ": the docs show \"" << k << "\", the type has not";
  }
  for (const auto& [k, v] : doc.members) {
    if (!typed.contains(k)) continue;
    if (!v.empty() && v.front() == '{' && typed[k].is_object())
      expect_same_keys(v, typed[k], path + "." + k);
    if (!v.empty() && v.front() == '[' && typed[k].is_array() && !typed[k].empty() &&
        typed[k][0].is_object()) {
      const auto first = v.find('{');
      if (first != std::string::npos)
        expect_same_keys(v.substr(first), typed[k][0], path + "." + k);
    }
  }
}

// The result examples of a method's section: the inline "→ `{…}`" and the fenced
// "result":{…}.
std::vector<std::string> result_examples(const std::string& section) {
  std::vector<std::string> out;
  for (const std::string marker : {"→ `{", "\"result\":{"}) {
    for (auto at = section.find(marker); at != std::string::npos; at = section.find(marker, at + 1))
      out.push_back(section.substr(at + marker.size() - 1));
  }
  return out;
}

Keys keys_of(const json& j) {
  Keys k;
  for (const auto& [key, v] : j.items()) k.insert(key);
  return k;
}

// Instances with every optional member set and one element in every list, so that their
// JSON shows every key the protocol has.
StatusResult full_status() {
  StatusResult s;
  s.daemon.tcp_port = 7878;
  s.daemon.access.control_group = "standcal";
  s.stand.busy_with = "stand.home";
  s.stand.axes.push_back(AxisStatus{});
  s.run = RunProgress{};
  return s;
}

RunStatusResult full_run_status() {
  RunStatusResult r;
  r.phase = "sampling";
  r.eta_s = 412;
  return r;
}

// Each documented method: its parameters (a request with every optional set) and the JSON
// of each shape its answer can take.
struct MethodShapes {
  std::string method;
  json params;
  std::vector<json> results;
};

std::vector<MethodShapes> method_shapes() {
  RunStartParams start;
  start.unit_type = "QA-3000";
  start.dwell_s = 60;
  start.settle_s = 5;
  start.warmup_s = 3600;
  start.operator_name = "J. Doe";
  RunsListParams list{"AU-0042", 10, "20261121T223638Z-AU-0042"};
  UnitReadResult read;
  read.temp_c = 23.0;
  RunsPage page;
  page.runs.push_back(RunListEntry{});
  const json none = json::object();
  const json target = RunTargetParams{"RUN"};
  return {
      {"status", none, {full_status()}},
      {"stand.enable", none, {EnabledResult{}}},
      {"stand.disable", none, {EnabledResult{}}},
      {"stand.home", none, {HomedResult{}}},
      {"stand.move", StandMoveParams{}, {MoveResult{}, MoveAccepted{}}},
      {"stand.stop", none, {StoppedResult{}}},
      {"estop", none, {EstopResult{}}},
      {"estop.reset", none, {EstopResult{}}},
      {"unit.read", UnitReadParams{}, {read}},
      {"run.start", start, {RunStarted{}}},
      {"run.pause", target, {RunStateResult{}}},
      {"run.resume", target, {RunResumed{}, RunStateResult{}}},
      {"run.abort", target, {RunStateResult{}}},
      {"run.status", target, {full_run_status()}},
      {"run.result", RunResultParams{}, {}},      // the fit's JSON: docs/calibration.md
      {"run.diagnose", RunDiagnoseParams{}, {}},  // the diagnosis's JSON: docs/diagnosis.md
      {"runs.list", list, {page}},
      {"operator.confirm", target, {ConfirmedResult{}}},
      {"subscribe", SubscribeParams{std::vector<std::string>{"fault"}}, {SubscribedResult{}}},
      {"auth", AuthParams{"token"}, {AuthResult{}}},
  };
}

// "`{alpha1_deg: number, wait?: bool = true}`", "`{program, unit_serial, unit_type?}`" or
// "no params": the parameter names.
Keys heading_params(const std::string& section) {
  const auto line_end = section.find('\n', 1);
  const std::string heading = section.substr(0, line_end);
  Keys names;
  const auto open = heading.find("`{");
  if (open == std::string::npos) return names;
  const auto close = heading.find("}`", open);
  // Without ranges ("[1/unit.sample_rate_hz, 3600]"): their commas are not between names.
  const std::string list = std::regex_replace(heading.substr(open + 2, close - open - 2),
                                              std::regex(R"(\[[^\]]*\])"), "");
  const std::regex name(R"((?:^|,)\s*([a-z_0-9]+)\??)");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), name); it != std::sregex_iterator();
       ++it)
    names.insert((*it)[1]);
  return names;
}

TEST(ProtocolMessages, EachMethodsParametersAreTheOnesItsHeadingLists) {
  const std::string doc = protocol_doc();
  ASSERT_FALSE(doc.empty()) << "docs/protocol.md";
  for (const MethodShapes& m : method_shapes()) {
    const std::string section = method_section(doc, m.method);
    ASSERT_FALSE(section.empty()) << m.method << " has no section in docs/protocol.md";
    EXPECT_EQ(heading_params(section), keys_of(m.params)) << m.method;
  }
}

TEST(ProtocolMessages, EachResultHasTheKeysItsExamplesShow) {
  const std::string doc = protocol_doc();
  for (const MethodShapes& m : method_shapes()) {
    if (m.results.empty()) continue;
    const std::string section = method_section(doc, m.method);
    const std::vector<std::string> examples = result_examples(section);
    ASSERT_FALSE(examples.empty()) << m.method << ": docs/protocol.md shows no result";
    // Every example is one of the method's shapes, and every shape has an example.
    std::set<std::size_t> shown;
    for (const std::string& example : examples) {
      const DocObject doc_object = parse_doc_object(example);
      Keys keys;
      for (const auto& [k, v] : doc_object.members) keys.insert(k);
      bool matched = false;
      for (std::size_t i = 0; i < m.results.size(); ++i) {
        if (keys_of(m.results[i]) != keys) continue;
        matched = true;
        shown.insert(i);
        expect_same_keys(example, m.results[i], m.method);
      }
      EXPECT_TRUE(matched) << m.method << ": the example " << example.substr(0, 80)
                           << " is none of the method's result types";
    }
    EXPECT_EQ(shown.size(), m.results.size())
        << m.method << ": a result shape has no example in docs/protocol.md";
  }
}

// The events table: "| `run.progress` | `run_id, state, position (1-based), …` — …|".
std::map<std::string, Keys> documented_events(const std::string& doc) {
  std::map<std::string, Keys> events;
  const auto start = doc.find("\n## Events");
  std::istringstream lines(doc.substr(start));
  std::string line;
  const std::regex row(R"(^\| `([a-z_.]+)` \| (.*) \|$)");
  while (std::getline(lines, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, row)) continue;
    std::string cells = m[2];
    cells = std::regex_replace(cells, std::regex(R"(\([^)]*\)|\[[^\]]*\]|"[^"]*"| — .*)"), "");
    Keys keys;
    const std::regex in_ticks("`([^`]*)`");
    for (auto it = std::sregex_iterator(cells.begin(), cells.end(), in_ticks);
         it != std::sregex_iterator(); ++it) {
      const std::string ticked = (*it)[1];
      const std::regex name("[a-z_0-9]+");
      for (auto n = std::sregex_iterator(ticked.begin(), ticked.end(), name);
           n != std::sregex_iterator(); ++n)
        keys.insert(n->str());
    }
    events[m[1]] = keys;
  }
  return events;
}

TEST(ProtocolMessages, EachEventHasTheKeysTheEventsTableLists) {
  PositionAveraged averaged;
  averaged.temp_c = 23.0;
  FaultEvent fault{"message", "RUN", 3, "estop"};
  const std::map<std::string, Keys> typed{
      {"run.progress", keys_of(RunProgress{})},
      {"run.position_reached", keys_of(PositionReached{})},
      {"run.position_averaged", keys_of(averaged)},
      {"run.state", keys_of(RunStateEvent{})},
      {"fault", keys_of(fault)},
  };
  EXPECT_EQ(documented_events(protocol_doc()), typed);
}

TEST(ProtocolMessages, TheGreetingHasTheKeysItsExampleShows) {
  const std::string doc = protocol_doc();
  const std::string marker = "\"method\":\"hello\",\"params\":{";
  const auto at = doc.find(marker);
  ASSERT_NE(at, std::string::npos) << "docs/protocol.md shows no hello";
  expect_same_keys(doc.substr(at + marker.size() - 1), Hello{}, "hello");
  Hello estop_only;
  estop_only.estop_only = true;
  estop_only.message = "one estop";
  EXPECT_EQ(json(json(estop_only).get<Hello>()), json(estop_only));
  EXPECT_FALSE(json(Hello{}).contains("estop_only"));  // absent unless on an estop-only slot
}

TEST(ProtocolMessages, ResultsAndEventsReadBackAsWritten) {
  StatusResult status = full_status();
  status.daemon.version = "1.2.3";
  status.stand.axes.push_back(AxisStatus{});
  status.stand.axes.back().axis = "inner";
  status.stand.axes.back().error = "link lost";
  status.run->eta_s = 12.5;
  const auto back = json(status).get<StatusResult>();
  EXPECT_EQ(json(back), json(status));
  EXPECT_EQ(back.stand.axes[1].error.value_or(""), "link lost");
  EXPECT_EQ(json(status.stand.axes[1]), (json{{"axis", "inner"}, {"error", "link lost"}}));

  PositionAveraged averaged{"RUN", 3, 2, 6000, {1, 2, 3}, {4, 5, 6}, {7, 8, 9}, std::nullopt};
  EXPECT_TRUE(json(averaged)["temp_c"].is_null());
  EXPECT_EQ(json(json(averaged).get<PositionAveraged>()), json(averaged));

  // A fault event carries only what it names.
  FaultEvent estop;
  estop.message = "emergency stop";
  estop.source = "estop";
  EXPECT_EQ(json(estop), (json{{"message", "emergency stop"}, {"source", "estop"}}));
  EXPECT_EQ(json(json(estop).get<FaultEvent>()), json(estop));

  // An older daemon's answer without a key reads as the default.
  const auto older = json{{"run_id", "R"}}.get<RunStatusResult>();
  EXPECT_EQ(older.run_id, "R");
  EXPECT_EQ(older.state, "");
}

TEST(ProtocolMessages, RequestsParseAsTheDaemonReadsThemAndNameWhatIsWrong) {
  RunStartParams start;
  start.program = "paper9";
  start.unit_serial = "AU-1";
  start.dwell_s = 60;
  start.warmup_s = 1800;
  const auto parsed = RunStartParams::parse(json(start));
  EXPECT_EQ(json(parsed), json(start));
  EXPECT_FALSE(json(start).contains("operator"));  // unset optionals are not sent

  EXPECT_FALSE(SubscribeParams::parse(json{{"events", "all"}}).events.has_value());
  EXPECT_FALSE(SubscribeParams::parse(json(SubscribeParams{})).events.has_value());
  EXPECT_EQ(RunsListParams::parse(json{{"limit", 5.0}}).limit, 5);

  const auto error_of = [](const auto& parse) -> std::string {
    try {
      parse();
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), static_cast<int>(ErrorCode::invalid_params));
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of([] {
              StandMoveParams::parse(json{{"alpha1_deg", 1}, {"alpha2", 2}});
            }).find("alpha2"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              RunStartParams::parse(json{{"program", "paper9"}});
            }).find("\"unit_serial\" is required"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              RunsListParams::parse(json{{"limit", 0}});
            }).find("limit"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              SubscribeParams::parse(json{{"events", 3}});
            }).find("events"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              parse_no_params(json{{"x", 1}}, "status");
            }).find("x"),
            std::string::npos);
}

}  // namespace
}  // namespace standcal::protocol
