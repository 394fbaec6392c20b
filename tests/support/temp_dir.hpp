#pragma once
// A fresh temporary directory for one test, removed with its files on destruction.
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace standcal::test {

class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "standcal-test") {
    std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
    if (::mkdtemp(pattern.data()) == nullptr)
      throw std::runtime_error("mkdtemp " + pattern + " failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  // Writes `text` to `name` atomically: a process watching the file (an emulator's control
  // file) never reads half of it.
  void write(const std::string& name, const std::string& text) const {
    const std::string temporary = file(name + ".tmp");
    std::ofstream(temporary) << text;
    std::filesystem::rename(temporary, file(name));
  }

 private:
  std::string path_;
};

}  // namespace standcal::test
