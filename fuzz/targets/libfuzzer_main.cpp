// libFuzzer's entry point for one target; STANDCAL_FUZZ_ENTRY names the
// standcal_fuzz_<target> function (fuzz/CMakeLists.txt sets it per executable).
#include "fuzz/targets/targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return STANDCAL_FUZZ_ENTRY(data, size);
}
