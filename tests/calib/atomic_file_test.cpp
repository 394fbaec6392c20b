// The one atomic file writer (calib/atomic_file.hpp) that run state, recordings,
// certificates and figures go through.
#include "calib/atomic_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "tests/support/temp_dir.hpp"

namespace standcal {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string write_error(const std::string& path, const std::string& text) {
  try {
    write_file_atomically(path, text, "the recording");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(AtomicFile, ReplacesTheFileWholeAndLeavesNoTemporary) {
  test::TempDir dir;
  const std::string path = dir.file("rec.csv");
  write_file_atomically(path, "old\n");
  write_file_atomically(path, "new\n");
  EXPECT_EQ(read_all(path), "new\n");
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(AtomicFile, ModeIsTheOneAskedLessTheUmask) {
  test::TempDir dir;
  const std::string path = dir.file("run.json");
  const mode_t old_mask = ::umask(022);
  write_file_atomically(path, "{}\n", "the run state", 0640);
  ::umask(old_mask);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640U);
}

TEST(AtomicFile, AFailedWriteKeepsTheOldFileAndSaysWhy) {
  test::TempDir dir;
  const std::string path = dir.file("rec.csv");
  write_file_atomically(path, "old\n");
  std::filesystem::create_directory(path + ".tmp");  // the temporary cannot be created
  const std::string why = write_error(path, "new\n");
  EXPECT_EQ(why.rfind(path + ": could not write the recording (create " + path + ".tmp: ", 0), 0U)
      << why;
  EXPECT_EQ(read_all(path), "old\n");
  std::filesystem::remove(path + ".tmp");

  EXPECT_EQ(write_error(dir.path(), "x"),
            dir.path() + ": could not write the recording (it is a directory)");
  const std::string missing = dir.file("no/such/dir/rec.csv");
  EXPECT_NE(write_error(missing, "x").find("No such file or directory"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(missing + ".tmp"));
}

TEST(AtomicFile, ADeviceIsWrittenInPlaceNotReplaced) {
  write_file_atomically("/dev/null", "into the device\n");
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));  // still the device
  test::TempDir dir;
  const std::string fifo = dir.file("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string seen;
  std::thread reader([&] { seen = read_all(fifo); });
  write_file_atomically(fifo, "through the pipe\n");
  reader.join();
  EXPECT_EQ(seen, "through the pipe\n");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
}

}  // namespace
}  // namespace standcal
