#!/usr/bin/env bash
# ThreadSanitizer pass over the whole test suite (not part of CI: slow).
#
#   scripts/tsan.sh [--build-dir DIR] [--target T]... [LABEL...]
#
# Configures a clang-14 -fsanitize=thread build (g++ if clang-14 is missing; default
# build/tsan, benchmarks off), builds it (or only the targets given), runs every test
# (or only the ctest labels given) except SLOW_MATHS below, and prints a summary: tests
# run/failed and the ThreadSanitizer reports of every process, test or child, by kind
# and location. Exits 1 on any failure or report. Suppressions: scripts/tsan.supp.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build/tsan"
labels=()
targets=()
while (($#)); do
  case "$1" in
    --build-dir) build="$2"; shift 2 ;;
    --target) targets+=(--target "$2"); shift 2 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    -*) echo "tsan.sh: unknown option '$1'" >&2; exit 2 ;;
    *) labels+=("$1"); shift ;;
  esac
done
# Pure single-threaded maths that TSan only slows down (no threads to check), so the
# full run stays within ~25 min on a 2-core machine. Empty while every test is feasible;
# add a ctest name regex here with its reason and measured time if one is not.
SLOW_MATHS=()

if command -v clang++-14 >/dev/null && command -v clang-14 >/dev/null; then
  # clang compiles the Eigen-heavy calib files much faster than g++ with instrumentation.
  compilers=(-DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14)
  compiler_name=clang-14
else
  compilers=()
  compiler_name=g++
fi
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi

flags="-fsanitize=thread -g -O1 -fno-omit-frame-pointer"
mkdir -p "$build"
echo "=== configuring $build ($compiler_name -fsanitize=thread) ===" >&2
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=None -DSTANDCAL_BUILD_BENCH=OFF \
  -DSTANDCAL_SANITIZE=OFF "${compilers[@]}" "${launcher[@]}" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" \
  >"$build/configure.log" 2>&1 || { cat "$build/configure.log" >&2; exit 1; }
echo "=== building (log: $build/build.log) ===" >&2
cmake --build "$build" -j "$(nproc)" "${targets[@]}" >"$build/build.log" 2>&1 || { tail -50 "$build/build.log" >&2; exit 1; }

select=()
if ((${#labels[@]})); then
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
  select=(-L "^($(IFS='|'; echo "${present[*]}"))\$")
  what="labels ${present[*]}"
else
  what="every test"
fi
if ((${#SLOW_MATHS[@]})); then
  select+=(-E "$(IFS='|'; echo "${SLOW_MATHS[*]}")")
  what="$what except ${SLOW_MATHS[*]}"
fi

# TSan's shadow memory needs a fixed layout: with the kernel's high mmap randomisation
# (vm.mmap_rnd_bits > 28) the runtimes abort with "unexpected memory mapping"; running
# without ASLR (setarch -R) avoids it.
runner=()
if [[ "$(cat /proc/sys/vm/mmap_rnd_bits 2>/dev/null || echo 0)" -gt 28 ]] && command -v setarch >/dev/null; then
  runner=(setarch "$(uname -m)" -R)
fi
# Every process writes its reports to reports/tsan.<pid>: the tests start daemons and
# emulators whose stderr ctest never sees, and their races count as much as the test's.
reports_dir="$build/reports"
rm -rf "$reports_dir" && mkdir -p "$reports_dir"
export TSAN_OPTIONS="halt_on_error=0:second_deadlock_stack=1:history_size=4:log_path=$reports_dir/tsan"
# Only third-party false positives belong there, each with its reason.
supp="$root/scripts/tsan.supp"
[[ -f "$supp" ]] && TSAN_OPTIONS="$TSAN_OPTIONS:suppressions=$supp"
echo "=== running $what under ThreadSanitizer ===" >&2
set +e
"${runner[@]}" ctest --test-dir "$build" "${select[@]}" --output-on-failure -j 2 --timeout 900 \
  >"$build/test.log" 2>&1
rc=$?
set -e

reports=$(cat "$reports_dir"/tsan.* 2>/dev/null | grep -c 'WARNING: ThreadSanitizer' || true)
echo
echo "=== ThreadSanitizer summary ($build, $what) ==="
grep -E 'tests passed|tests failed' "$build/test.log" || true
sed -n '/The following tests FAILED/,$p' "$build/test.log" | head -40
echo "ThreadSanitizer reports: ${reports:-0}"
if [[ "${reports:-0}" != 0 ]]; then
  # One line per distinct report kind and location.
  cat "$reports_dir"/tsan.* | grep -E 'SUMMARY: ThreadSanitizer' | sort | uniq -c | sort -rn | head -30 || true
fi
echo "full output: $build/test.log, reports in $reports_dir"
if ((rc != 0)) || [[ "${reports:-0}" != 0 ]]; then exit 1; fi
