#!/usr/bin/env bash
# The whole test suite: a Release build and an AddressSanitizer+UBSan build, warnings as
# errors in both, every test in both. Slower checks (TSan, fuzzing) are separate scripts.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# The fault-injection tests (label faults) spend nearly all their time waiting on link
# timeouts and a stand emulator moving in real time (measured: 4 of them, 37 s of test
# time, 2.3 s of CPU), so they run four at a time, after the CPU-bound tests rather than
# beside them: a starved daemon or emulator would miss its 1 s link timeout and fail a
# test for the wrong reason.
cpu_bound_tests() {
  ctest --test-dir "$1" -LE '^faults$' --output-on-failure -j "$(nproc)" --timeout 600
}
fault_tests() {
  ctest --test-dir "$1/tests/faults" --output-on-failure -j 4 --timeout 600
}

echo "=== release build ===" >&2
"$root/scripts/build.sh" release
echo "=== release tests ===" >&2
cpu_bound_tests "$root/build/release"
# The sanitizer build compiles while the release fault tests wait, at the lowest priority
# so that it only takes the CPU time they leave.
asan_log="$root/build/asan-build.log"
mkdir -p "$root/build"
nice -n 19 "$root/scripts/build.sh" asan >"$asan_log" 2>&1 &
asan_build=$!
fault_rc=0
fault_tests "$root/build/release" || fault_rc=$?
echo "=== asan build (log: $asan_log) ===" >&2
if ! wait "$asan_build"; then
  tail -60 "$asan_log" >&2
  echo "test.sh: the asan build failed (full log: $asan_log)" >&2
  exit 1
fi
tail -3 "$asan_log" >&2
((fault_rc == 0)) || { echo "test.sh: release fault-injection tests failed" >&2; exit "$fault_rc"; }
echo "=== asan tests ===" >&2
cpu_bound_tests "$root/build/asan"
fault_tests "$root/build/asan"
