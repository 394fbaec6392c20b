#pragma once
// What every replay test needs: its recorded inputs, their lines, and the comparison
// with the checked-in expected output (or its regeneration).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace standcal::test {

inline std::vector<std::string> files_in(const std::string& folder, const std::string& extension) {
  std::vector<std::string> names;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(STANDCAL_REPLAY_DIR) + "/" + folder)) {
    if (e.path().extension() == extension) names.push_back(e.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

inline std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Compares `got` with the .chk file, or writes it there when regenerating.
inline void check_against(const std::string& chk_path, const std::string& got) {
  if (const char* r = std::getenv("STANDCAL_REPLAY_REGENERATE"); r && std::string(r) == "1") {
    std::ofstream(chk_path) << got;
    GTEST_SKIP() << "regenerated " << chk_path;
  }
  std::ifstream in(chk_path);
  ASSERT_TRUE(in) << "no expected output " << chk_path
                  << " (STANDCAL_REPLAY_REGENERATE=1 writes it)";
  std::stringstream expected;
  expected << in.rdbuf();
  if (expected.str() == got) return;
  // The first differing line, numbered, is what a reviewer needs.
  std::istringstream e(expected.str()), g(got);
  std::string el, gl;
  for (int n = 1;; ++n) {
    const bool more_e = static_cast<bool>(std::getline(e, el));
    const bool more_g = static_cast<bool>(std::getline(g, gl));
    if (!more_e && !more_g) break;
    if (!more_e || !more_g || el != gl) {
      FAIL() << chk_path << ":" << n << " differs\n  expected: " << (more_e ? el : "(end)")
             << "\n  got:      " << (more_g ? gl : "(end)");
    }
  }
}

}  // namespace standcal::test
