// runs.list pages (docs/protocol.md): a state directory of 250 runs, written by the run
// store as a long-lived bench PC's would be, listed by the real daemon page by page and by
// the real CLI; a bad `limit` is an invalid-params error that names it.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "daemon/standcald/run_store.hpp"
#include "daemon_process.hpp"
#include "tests/support/command.hpp"

using namespace standcal;
using nlohmann::json;
using protocol::Client;
using protocol::RpcError;
using test::DaemonProcess;
using test::socket_of;
using test::TempDir;

namespace {

constexpr int kRuns = 250;

// kRuns finished runs a minute apart, alternating between two units; ids newest last.
std::vector<std::string> write_runs(const std::string& state_dir) {
  daemon::RunStore store(state_dir);
  std::vector<std::string> ids;
  for (int i = 0; i < kRuns; ++i) {
    daemon::RunRecord r;
    r.unit_serial = i % 2 == 0 ? "AU-1" : "AU-2";
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "20261201T%02d%02d00Z", 8 + i / 60, i % 60);
    r.run_id = std::string(stamp) + "-" + r.unit_serial;
    std::filesystem::create_directories(store.run_dir(r.run_id));
    r.state = "done";
    r.positions = r.positions_done = 9;
    store.save(r);
    ids.push_back(r.run_id);
  }
  return ids;
}

int error_code(Client& c, const json& params) {
  try {
    c.call("runs.list", params);
  } catch (const RpcError& e) {
    EXPECT_NE(std::string(e.what()).find("limit"), std::string::npos) << e.what();
    return e.code();
  }
  return 0;
}

}  // namespace

TEST(DaemonRunsList, PagesCoverEveryRunOnceNewestFirst) {
  TempDir dir;
  const std::vector<std::string> ids = write_runs(dir.path() + "/state");
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));

  json page = c.call("runs.list");
  ASSERT_EQ(page["runs"].size(), 100u);  // the default page
  EXPECT_TRUE(page["more"].get<bool>());
  EXPECT_EQ(page["runs"][0]["run_id"], ids.back());

  std::vector<std::string> seen;
  page = c.call("runs.list", {{"limit", 64}});
  for (;;) {
    for (const json& r : page["runs"]) seen.push_back(r["run_id"]);
    if (!page["more"].get<bool>()) break;
    page = c.call("runs.list", {{"limit", 64}, {"before", seen.back()}});
  }
  EXPECT_EQ(seen, std::vector<std::string>(ids.rbegin(), ids.rend()));

  const json au2 = c.call("runs.list", {{"unit_serial", "AU-2"}, {"limit", 1000}});
  EXPECT_EQ(au2["runs"].size(), static_cast<std::size_t>(kRuns / 2));
  EXPECT_FALSE(au2["more"].get<bool>());
  for (const json& r : au2["runs"]) ASSERT_EQ(r["unit_serial"], "AU-2");
}

TEST(DaemonRunsList, ABadLimitIsAnInvalidParamsErrorNamingIt) {
  TempDir dir;
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  Client c(socket_of(dir));
  for (const json& limit : {json(0), json(1001), json(2.5), json("ten"), json(-3)}) {
    EXPECT_EQ(error_code(c, {{"limit", limit}}), -32602) << limit.dump();
  }
  EXPECT_EQ(c.call("runs.list", {{"limit", 5.0}})["runs"].size(), 0u);  // 5.0 is a whole number
}

TEST(DaemonRunsList, TheCliShowsOnePageAndSaysHowToGetOlderRunsOrAll) {
  TempDir dir;
  const std::vector<std::string> ids = write_runs(dir.path() + "/state");
  auto daemon = DaemonProcess::sim(dir.path(), 100);
  const std::string socket = " --socket " + socket_of(dir);

  const test::CommandOutcome five = test::standcal_cli("runs --limit 5" + socket);
  ASSERT_EQ(five.exit_code, 0) << five.output;
  EXPECT_NE(five.output.find(ids[kRuns - 1]), std::string::npos) << five.output;
  EXPECT_NE(five.output.find(ids[kRuns - 5]), std::string::npos) << five.output;
  EXPECT_EQ(five.output.find(ids[kRuns - 6]), std::string::npos) << five.output;
  EXPECT_NE(five.output.find("standcal runs --before " + ids[kRuns - 5]), std::string::npos)
      << five.output;

  const test::CommandOutcome unit_page =
      test::standcal_cli("runs --unit-serial AU-2 --limit 3" + socket);
  ASSERT_EQ(unit_page.exit_code, 0) << unit_page.output;
  EXPECT_NE(unit_page.output.find("standcal runs --unit-serial AU-2 --before " + ids[kRuns - 5]),
            std::string::npos)
      << unit_page.output;

  // --all in pages of 16: each of one unit's 125 runs once.
  const test::CommandOutcome all =
      test::standcal_cli("runs --all --limit 16 --json --unit AU-1" + socket);
  ASSERT_EQ(all.exit_code, 0) << all.output;
  const json listed = json::parse(all.output);
  std::set<std::string> unique;
  for (const json& r : listed["runs"]) unique.insert(r["run_id"].get<std::string>());
  EXPECT_EQ(listed["runs"].size(), static_cast<std::size_t>(kRuns / 2));
  EXPECT_EQ(unique.size(), static_cast<std::size_t>(kRuns / 2));
  EXPECT_FALSE(listed["more"].get<bool>());

  const test::CommandOutcome bad = test::standcal_cli("runs --limit 0" + socket);
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--limit"), std::string::npos) << bad.output;
}
