// The one method table (daemon/standcald/method_table.hpp) against the sequencer's handlers,
// the access rule and docs/protocol.md: a method added in one place and not the others fails
// here, not in front of an operator.
#include "daemon/standcald/method_table.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "daemon/standcald/sequencer.hpp"
#include "daemon/standcald/server.hpp"
#include "protocol/jsonrpc/methods.hpp"

namespace standcal::daemon {
namespace {

std::set<std::string> table_names(std::optional<Executor> executor = std::nullopt) {
  std::set<std::string> names;
  for (const MethodSpec& s : method_table()) {
    if (!executor || s.executor == *executor) names.insert(std::string(s.name));
  }
  return names;
}

TEST(MethodTable, EachMethodOnce) {
  std::set<std::string> seen;
  for (const MethodSpec& s : method_table())
    EXPECT_TRUE(seen.insert(std::string(s.name)).second) << s.name << " twice";
  EXPECT_EQ(seen.size(), 20u);
  EXPECT_EQ(find_method("stand.calibrate_encoders"), nullptr);
  ASSERT_NE(find_method(protocol::method::run_diagnose), nullptr);
  EXPECT_EQ(find_method(protocol::method::run_diagnose)->executor, Executor::diagnose_worker);
}

TEST(MethodTable, TheSequencerHandlesExactlyItsRows) {
  std::set<std::string> handled;
  for (std::string_view m : Sequencer::handled_methods()) handled.insert(std::string(m));
  EXPECT_EQ(handled, table_names(Executor::sequencer));
  for (const MethodSpec& s : method_table())
    EXPECT_EQ(Sequencer::handles(s.name), s.executor == Executor::sequencer) << s.name;
}

TEST(MethodTable, TheServerAnswersExactlyItsRows) {
  std::set<std::string> answered;
  for (std::string_view m : Server::answered_methods())
    EXPECT_TRUE(answered.insert(std::string(m)).second) << m << " twice";
  EXPECT_EQ(answered, table_names(Executor::server));
}

TEST(MethodTable, AccessFollowsTheTable) {
  // Open: the views, subscribe, auth, the diagnosis and the emergency stop.
  std::set<std::string> open;
  for (const MethodSpec& s : method_table()) {
    EXPECT_EQ(is_open_method(std::string(s.name)), s.access == Access::anyone) << s.name;
    if (s.access == Access::anyone) open.insert(std::string(s.name));
  }
  EXPECT_EQ(open, (std::set<std::string>{"status", "run.status", "run.result", "runs.list",
                                         "subscribe", "auth", "run.diagnose", "estop"}));
}

TEST(MethodTable, DocsProtocolDescribesEveryMethodAndNoOther) {
  std::ifstream in(std::string(STANDCAL_SOURCE_DIR) + "/docs/protocol.md");
  ASSERT_TRUE(in) << "docs/protocol.md";
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const auto methods_at = doc.find("\n## Methods");
  const auto events_at = doc.find("\n## Events");
  ASSERT_NE(methods_at, std::string::npos);
  ASSERT_NE(events_at, std::string::npos);
  const std::string section = doc.substr(methods_at, events_at - methods_at);
  // One heading per method: "### `name` — params".
  std::set<std::string> documented;
  const std::regex heading(R"(\n### `([a-z_.]+)` )");
  for (auto it = std::sregex_iterator(section.begin(), section.end(), heading);
       it != std::sregex_iterator(); ++it)
    documented.insert((*it)[1]);
  EXPECT_EQ(documented, table_names());
}

}  // namespace
}  // namespace standcal::daemon
