// The state directory on its own: run records, the per-unit index, interrupted runs after
// a crash, and the recording cut back to its last durable position on resume.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "daemon/standcald/run_store.hpp"
#include "daemon_process.hpp"

using namespace standcal::daemon;
using standcal::test::TempDir;

namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
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
  const auto au1 = store.list("AU-1");
  ASSERT_EQ(au1.size(), 2u);
  EXPECT_NE(au1[0].run_id, au1[1].run_id);
  EXPECT_GT(au1[0].run_id, au1[1].run_id);  // newest first
  EXPECT_EQ(store.list().size(), 3u);
  EXPECT_FALSE(store.latest_resumable().has_value());
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
