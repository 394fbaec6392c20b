#include "fuzz/targets/fuzz_support.hpp"

#include <cstdio>
#include <cstdlib>

namespace standcal::fuzz {

namespace {

[[noreturn]] void print_and_abort(const std::string& what) {
  std::fprintf(stderr, "standcal fuzz finding: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();  // libFuzzer saves the input as crash-<sha1>
}

FindingHandler g_handler = nullptr;

}  // namespace

void set_finding_handler(FindingHandler handler) { g_handler = handler; }

void report_finding(const std::string& what) {
  if (g_handler != nullptr) g_handler(what);
  // A handler must not return; if it does, fall back to aborting.
  print_and_abort(what);
}

}  // namespace standcal::fuzz
