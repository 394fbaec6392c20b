#!/usr/bin/env bash
# ThreadSanitizer pass over the tests that involve threads (not part of CI: slow).
#
#   scripts/tsan.sh [--build-dir DIR] [--target T]... [LABEL...]
#
# Configures a g++ -fsanitize=thread build (default build/tsan, benchmarks off), builds
# it (or only the targets given: the test executables of the labels), runs the ctest labels drivers_modbus, drivers_can, drivers_sim and daemon (those
# present; or the labels given) and prints a summary: tests run/failed and the data races
# and other ThreadSanitizer reports, by location. Exits 1 on any failure or report.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build/tsan"
labels=()
targets=()
while (($#)); do
  case "$1" in
    --build-dir) build="$2"; shift 2 ;;
    --target) targets+=(--target "$2"); shift 2 ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    -*) echo "tsan.sh: unknown option '$1'" >&2; exit 2 ;;
    *) labels+=("$1"); shift ;;
  esac
done
((${#labels[@]})) || labels=(drivers_modbus drivers_can drivers_sim daemon)

flags="-fsanitize=thread -g -O1 -fno-omit-frame-pointer"
mkdir -p "$build"
echo "=== configuring $build (g++ -fsanitize=thread) ===" >&2
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTANDCAL_BUILD_BENCH=OFF \
  -DSTANDCAL_SANITIZE=OFF -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" \
  >"$build/configure.log" 2>&1 || { cat "$build/configure.log" >&2; exit 1; }
echo "=== building (log: $build/build.log) ===" >&2
cmake --build "$build" -j "$(nproc)" "${targets[@]}" >"$build/build.log" 2>&1 || { tail -50 "$build/build.log" >&2; exit 1; }

# Only the labels this tree has tests for.
present=()
for l in "${labels[@]}"; do
  if ctest --test-dir "$build" -N -L "^$l\$" 2>/dev/null | grep -q 'Total Tests: [1-9]'; then
    present+=("$l")
  else
    echo "tsan.sh: no tests labelled '$l' in this tree; skipped" >&2
  fi
done
((${#present[@]})) || { echo "tsan.sh: no tests to run" >&2; exit 1; }
regex="^($(IFS='|'; echo "${present[*]}"))\$"

# TSan's shadow memory needs a fixed layout: with the kernel's high mmap randomisation
# (vm.mmap_rnd_bits > 28) gcc 12's runtime aborts with "unexpected memory mapping";
# running without ASLR (setarch -R) avoids it.
runner=()
if [[ "$(cat /proc/sys/vm/mmap_rnd_bits 2>/dev/null || echo 0)" -gt 28 ]] && command -v setarch >/dev/null; then
  runner=(setarch "$(uname -m)" -R)
fi
export TSAN_OPTIONS="halt_on_error=0:second_deadlock_stack=1:history_size=4"
echo "=== running labels ${present[*]} under ThreadSanitizer ===" >&2
set +e
"${runner[@]}" ctest --test-dir "$build" -L "$regex" --output-on-failure -j 2 --timeout 900 \
  >"$build/test.log" 2>&1
rc=$?
set -e

log="$build/Testing/Temporary/LastTest.log"
reports=$(grep -c 'WARNING: ThreadSanitizer' "$log" 2>/dev/null || true)
echo
echo "=== ThreadSanitizer summary ($build) ==="
grep -E 'tests passed|tests failed' "$build/test.log" || true
sed -n '/The following tests FAILED/,$p' "$build/test.log" | head -40
echo "ThreadSanitizer reports: ${reports:-0}"
if [[ "${reports:-0}" != 0 ]]; then
  # One line per distinct report kind and the first frame of our code in it.
  grep -E 'WARNING: ThreadSanitizer|SUMMARY: ThreadSanitizer' "$log" | sort | uniq -c | sort -rn | head -30
fi
echo "full output: $build/test.log and $log"
if ((rc != 0)) || [[ "${reports:-0}" != 0 ]]; then exit 1; fi
