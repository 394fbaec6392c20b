#!/usr/bin/env bash
# Configures and builds one flavour of standcal: release (default) or asan; all of it, or
# only the targets named (and what they need).
#   scripts/build.sh [release|asan] [TARGET...]   -> build/<flavour>
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
flavour="${1:-release}"
targets=("${@:2}")
"$root/scripts/setup.sh"
# Both flavours use clang and lld: on this tree's Eigen-heavy code clang -O2 takes about
# half the CPU time of g++ -O3 (measured on the heaviest unity batch of calib/: 55 s
# against 106 s), and lld links the sanitized test binaries several times faster than
# ld.bfd. g++ still builds the Debian package (scripts/package.sh), the TSan build and
# plain `cmake` builds, so both compilers' warnings are kept in use.
clang=(-DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_C_COMPILER=clang-14
       -DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=lld -DCMAKE_SHARED_LINKER_FLAGS=-fuse-ld=lld)
case "$flavour" in
  # -O2, as Debian builds its packages (-O3 costs 40 % more compile time for nothing
  # bench/ can measure).
  release) flags=(-DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O2 -DNDEBUG"
                  "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG" "${clang[@]}") ;;
  # -g1: line tables for sanitizer reports at a fraction of full debug info's build time;
  # -O0 except calib/ (-O1, CMakeLists.txt).
  asan) flags=(-DCMAKE_BUILD_TYPE=None "-DCMAKE_CXX_FLAGS=-O0 -g1" "-DCMAKE_C_FLAGS=-O0 -g1"
               "${clang[@]}" -DSTANDCAL_SANITIZE=ON -DSTANDCAL_BUILD_BENCH=OFF) ;;
  *) echo "build.sh: unknown flavour '$flavour' (release, asan)" >&2; exit 2 ;;
esac
# Unity build: 32 sources per compiler run, so the heavy headers (Eigen, nlohmann, CLI11,
# spdlog, gtest) are parsed, and the Eigen templates they share instantiated, once per batch
# rather than once per file (measured on the ASan build, 2026-12-02: 16 per batch took 520 s
# of compiler CPU and 332 s on 2 cores, 8 per batch 652 s and 381 s; on 2026-12-05, scratch
# build directories of c1152dc, 32 against 16: Release 595 s of CPU and 291 s against 686 s
# and 336 s, the ASan build of CI's targets 494 s and 240 s against 503-553 s and 245-270 s).
# It also makes file-local names that clash between sources of one target a compile error.
# Plain per-file builds (cmake without this flag, scripts/tsan.sh, scripts/fuzz.sh) still
# work.
cmake -S "$root" -B "$root/build/$flavour" -G Ninja -DCMAKE_UNITY_BUILD=ON \
  -DCMAKE_UNITY_BUILD_BATCH_SIZE=32 "${flags[@]}" >/dev/null
cmake --build "$root/build/$flavour" -j "$(nproc)" ${targets[@]+--target "${targets[@]}"}
