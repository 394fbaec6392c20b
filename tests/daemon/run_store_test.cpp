// The state directory on its own: run records, the per-unit index, interrupted runs after
// a crash, and the recording cut back to its last durable position on resume.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "daemon/standcald/run_store.hpp"
#include "daemon_process.hpp"

using namespace standcal::daemon;
using standcal::test::TempDir;

namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Every run (of `unit_serial` when not empty), newest first: one unbounded page.
std::vector<RunSummary> every_run(const RunStore& store, const std::string& unit_serial = "") {
  RunPageQuery q;
  q.unit_serial = unit_serial;
  return store.page(q).runs;
}

}  // namespace

TEST(RunStore, ARunLeftRunningByACrashIsInterruptedOnTheNextStart) {
  TempDir dir;
  std::string id;
  {
    RunStore store(dir.path());
    RunRecord r;
    r.run_id = id = store.new_run_id("AU-9");
    r.unit_serial = "AU-9";
    r.state = "running";
    r.positions = 9;
    r.positions_done = 4;
    store.save(r);
  }  // "crash": the store is gone with the run still running
  RunStore again(dir.path());
  const auto r = again.get(id);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->state, "interrupted");
  EXPECT_EQ(r->positions_done, 4);
  ASSERT_TRUE(again.latest_resumable().has_value());
  EXPECT_EQ(again.latest_resumable()->run_id, id);
  EXPECT_NE(read_all(dir.path() + "/units/AU-9.json").find(id), std::string::npos);
}

// Serials differing only in bytes outside [A-Za-z0-9._-] used to share one units/*.json
// (all became "_") and overwrite each other's run list.
std::string long_serial(const std::string& character, const std::string& last) {
  std::string s;
  for (int i = 0; i < 63; ++i) s += character;
  return s + last;
}

TEST(RunStore, EverySerialHasItsOwnUnitIndexAndPlainSerialsKeepTheirFileNames) {
  TempDir dir;
  const std::vector<std::string> serials{
      "a/b", std::string("a\0b", 3), "a_b", "AU,1", "AU\t1", "AU_1", "AU%2C1", ".hidden", "AU-0042",
      // 64 characters of 4 bytes each (the longest serial the protocol takes): encoded
      // whole they would pass a file name's 255 bytes; two that differ only at the end.
      long_serial("\xF0\x90\x8D\x88", "A"), long_serial("\xF0\x90\x8D\x88", "B")};
  {
    RunStore store(dir.path());
    for (const std::string& serial : serials) {
      RunRecord r;
      r.run_id = store.new_run_id(serial);
      r.unit_serial = serial;
      r.state = "done";
      store.save(r);
    }
  }
  std::map<std::string, nlohmann::json> index_by_serial;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path() + "/units")) {
    const std::string name = entry.path().filename().string();
    EXPECT_NE(name.front(), '.') << name;
    EXPECT_LE(name.size() + 4, 255u) << name;  // with the writer's ".tmp"
    const nlohmann::json index = nlohmann::json::parse(read_all(entry.path().string()));
    index_by_serial[index["unit_serial"].get<std::string>()] = index;
  }
  ASSERT_EQ(index_by_serial.size(), serials.size()) << "two serials share an index file";
  for (const std::string& serial : serials) EXPECT_EQ(index_by_serial[serial]["runs"].size(), 1u);
  // Existing state directories still read: a plain serial's file name is unchanged.
  EXPECT_TRUE(std::filesystem::exists(dir.path() + "/units/AU-0042.json"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() + "/units/a_b.json"));
}

TEST(RunStore, RunIdsAreUniqueAndListedNewestFirstPerUnit) {
  TempDir dir;
  RunStore store(dir.path());
  for (const char* serial : {"AU-1", "AU-2", "AU-1"}) {
    RunRecord r;
    r.run_id = store.new_run_id(serial);
    r.unit_serial = serial;
    r.state = "done";
    store.save(r);
  }
  const auto au1 = every_run(store, "AU-1");
  ASSERT_EQ(au1.size(), 2u);
  EXPECT_NE(au1[0].run_id, au1[1].run_id);
  EXPECT_GT(au1[0].run_id, au1[1].run_id);  // newest first
  EXPECT_EQ(every_run(store).size(), 3u);
  EXPECT_FALSE(store.latest_resumable().has_value());
}

TEST(RunStore, RunsOfOneUnitStartedInTheSameSecondListInTheOrderTheyStarted) {
  TempDir dir;
  RunStore store(dir.path());
  std::vector<std::string> started;
  for (int i = 0; i < 12; ++i) {
    RunRecord r;
    r.run_id = store.new_run_id("AU-5");
    r.unit_serial = "AU-5";
    r.state = "done";
    store.save(r);
    started.push_back(r.run_id);
  }
  std::vector<std::string> listed;
  for (const RunSummary& r : every_run(store, "AU-5")) listed.push_back(r.run_id);
  EXPECT_EQ(listed, std::vector<std::string>(started.rbegin(), started.rend()));
}

TEST(RunStore, PagesAreNewestFirstBoundedAndContinueFromTheLastRunId) {
  TempDir dir;
  RunStore store(dir.path());
  // Seven runs a minute apart, alternating units: ids sort by start time.
  std::vector<std::string> ids;
  for (int i = 0; i < 7; ++i) {
    RunRecord r;
    r.unit_serial = i % 2 == 0 ? "AU-1" : "AU-2";
    r.run_id = "20261201T10" + std::to_string(10 + i) + "00Z-" + r.unit_serial;
    std::filesystem::create_directories(store.run_dir(r.run_id));
    r.state = "done";
    store.save(r);
    ids.push_back(r.run_id);
  }
  const RunPage first = store.page(RunPageQuery{"", "", 3});
  ASSERT_EQ(first.runs.size(), 3u);
  EXPECT_TRUE(first.more);
  EXPECT_EQ(first.runs[0].run_id, ids[6]);
  EXPECT_EQ(first.runs[2].run_id, ids[4]);

  const RunPage second = store.page(RunPageQuery{"", first.runs.back().run_id, 3});
  ASSERT_EQ(second.runs.size(), 3u);
  EXPECT_EQ(second.runs[0].run_id, ids[3]);
  EXPECT_TRUE(second.more);
  const RunPage last = store.page(RunPageQuery{"", second.runs.back().run_id, 3});
  ASSERT_EQ(last.runs.size(), 1u);
  EXPECT_EQ(last.runs[0].run_id, ids[0]);
  EXPECT_FALSE(last.more);

  // A unit's pages skip the other unit's runs; a page that ends exactly at the last
  // matching run says there is no more.
  const RunPage au2 = store.page(RunPageQuery{"AU-2", "", 3});
  ASSERT_EQ(au2.runs.size(), 3u);
  EXPECT_EQ(au2.runs[0].run_id, ids[5]);
  EXPECT_EQ(au2.runs[2].run_id, ids[1]);
  EXPECT_FALSE(au2.more);

  // `before` need not name a stored run: it is a position in time.
  const RunPage older = store.page(RunPageQuery{"AU-1", "20261201T101330Z", 10});
  ASSERT_EQ(older.runs.size(), 2u);
  EXPECT_EQ(older.runs[0].run_id, ids[2]);
  ASSERT_TRUE(store.newest().has_value());
  EXPECT_EQ(store.newest()->run_id, ids[6]);
}

TEST(RecordingFile, ReopenCutsOffWhatACrashLeftAfterTheLastDurablePosition) {
  TempDir dir;
  const std::string path = dir.path() + "/recording.csv";
  std::uint64_t durable = 0;
  {
    RecordingFile f = RecordingFile::create(path, "# format: standcal-recording/1\nt_s,pos\n");
    durable = f.append_durably("0.0,0\n0.1,0\n");
  }
  {
    std::ofstream tail(path, std::ios::app);
    tail << "0.2,1\n0.3,1\n0.4,";  // a position half written when the power went
  }
  RecordingFile f = RecordingFile::reopen(path, durable);
  EXPECT_EQ(read_all(path), "# format: standcal-recording/1\nt_s,pos\n0.0,0\n0.1,0\n");
  f.append_durably("0.2,1\n");
  EXPECT_EQ(read_all(path), "# format: standcal-recording/1\nt_s,pos\n0.0,0\n0.1,0\n0.2,1\n");
  // A recording shorter than its record says was tampered with or lost: refuse.
  EXPECT_THROW(RecordingFile::reopen(path, 100000), std::runtime_error);
}

// Memory holds a summary per run; the full record (programme, byte offsets) is read back
// from run.json when asked for, and is the same as what was saved.
TEST(RunStore, FullRecordsOfEarlierRunsAreReadBackFromDisk) {
  TempDir dir;
  RunStore store(dir.path());
  RunRecord first;
  first.run_id = store.new_run_id("AU-7");
  first.unit_serial = "AU-7";
  first.program_name = "paper9";
  first.program = {{"name", "paper9"}, {"positions", {{{"alpha1_deg", 0}, {"alpha2_deg", 90}}}}};
  first.state = "done";
  first.positions = 9;
  first.positions_done = 9;
  first.position_end_bytes = {120, 240, 360};
  first.result_path = store.run_dir(first.run_id) + "/result.json";
  store.save(first);
  RunRecord second = first;
  second.run_id = store.new_run_id("AU-8");
  second.unit_serial = "AU-8";
  second.result_path.clear();
  store.save(second);  // `first` is no longer the run saved last

  const auto back = store.get(first.run_id);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(to_json(*back), to_json(first));
  const auto listed = every_run(store, "AU-7");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].run_id, first.run_id);
  EXPECT_EQ(listed[0].program, "paper9");
  EXPECT_EQ(listed[0].positions_done, 9);
  EXPECT_TRUE(listed[0].has_result);
  EXPECT_FALSE(every_run(store, "AU-8")[0].has_result);
  EXPECT_FALSE(store.get("no-such-run").has_value());
  EXPECT_FALSE(store.get("../../etc").has_value());  // only ids the store made are looked up
}

// A save whose file write fails (disk full; here run.json.tmp is a directory, so the
// write fails even as root) keeps the new state in memory, also after another run is
// saved, until a save of that run reaches the disk.
TEST(RunStore, AStateTheDiskRefusedIsStillReportedFromMemory) {
  TempDir dir;
  RunStore store(dir.path());
  RunRecord r;
  r.run_id = store.new_run_id("AU-5");
  r.unit_serial = "AU-5";
  r.state = "running";
  store.save(r);
  const std::string blocker = store.run_dir(r.run_id) + "/run.json.tmp";
  std::filesystem::create_directory(blocker);
  r.state = "faulted";
  r.reason = "stand axis 2 did not reach 57.470°";
  EXPECT_THROW(store.save(r), std::runtime_error);
  RunRecord other;
  other.run_id = store.new_run_id("AU-6");
  other.unit_serial = "AU-6";
  other.state = "running";
  store.save(other);
  ASSERT_TRUE(store.get(r.run_id).has_value());
  EXPECT_EQ(store.get(r.run_id)->state, "faulted");
  EXPECT_EQ(store.get(r.run_id)->reason, r.reason);
  EXPECT_EQ(every_run(store, "AU-5")[0].state, "faulted");
  ASSERT_TRUE(store.latest_resumable().has_value());
  EXPECT_EQ(store.latest_resumable()->run_id, r.run_id);
  EXPECT_NE(read_all(store.run_dir(r.run_id) + "/run.json").find("\"running\""), std::string::npos);

  std::filesystem::remove(blocker);  // the disk has room again
  store.save(other);
  EXPECT_EQ(store.get(r.run_id)->state, "faulted");  // still held: its file is stale
  store.save(r);
  EXPECT_NE(read_all(store.run_dir(r.run_id) + "/run.json").find("\"faulted\""), std::string::npos);
  EXPECT_EQ(store.get(r.run_id)->state, "faulted");
}
