#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang 14 with ASan+UBSan) and runs each for a
# bounded time from its checked-in seed corpus. docs/fuzzing.md.
#
#   scripts/fuzz.sh [--seconds N] [--build-dir DIR] [--keep-corpus] [TARGET...]
#
# Defaults: 30 s per target, build dir build/fuzz, every target. New inputs libFuzzer finds
# go to DIR/corpus/<target> (never into fuzz/corpus: minimise and check in by hand);
# crashes go to DIR/artifacts/<target>/ (emptied at the start of each run: save a finding
# under fuzz/regressions/<target>/ before running again). Prints one line per target (runs, execs/s,
# coverage, crashes) and exits 1 if any target found something.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds=30
build="$root/build/fuzz"
keep=0
targets=()
while (($#)); do
  case "$1" in
    --seconds) seconds="$2"; shift 2 ;;
    --build-dir) build="$2"; shift 2 ;;
    --keep-corpus) keep=1; shift ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option '$1'" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "fuzz.sh: --seconds needs a whole number, got '$seconds'" >&2; exit 2; }

"$root/scripts/setup.sh"
cc="$(command -v clang-14 || command -v clang || true)"
cxx="$(command -v clang++-14 || command -v clang++ || true)"
if [[ -z "$cc" || -z "$cxx" ]]; then
  echo "fuzz.sh: clang (clang-14) is needed for libFuzzer; install the Debian package clang-14" >&2
  exit 2
fi

mkdir -p "$build"
echo "=== configuring $build ($cxx) ===" >&2
CC="$cc" CXX="$cxx" cmake -S "$root/fuzz" -B "$build" -G Ninja >"$build/configure.log" 2>&1 ||
  { cat "$build/configure.log" >&2; exit 1; }
echo "=== building the fuzz targets ===" >&2
cmake --build "$build" -j "$(nproc)" --target standcal_fuzzers >"$build/build.log" 2>&1 ||
  { tail -50 "$build/build.log" >&2; exit 1; }
((${#targets[@]})) || mapfile -t targets <"$build/fuzz-targets.txt"

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:symbolize=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
failed=0
printf '%-18s %8s %10s %9s %6s %6s  %s\n' target seconds runs 'execs/s' cov corpus result
for t in "${targets[@]}"; do
  exe="$build/standcal_fuzz_$t"
  seeds="$root/fuzz/corpus/$t"
  [[ -x "$exe" ]] || { echo "fuzz.sh: no fuzz target '$t' (see $build/fuzz-targets.txt)" >&2; exit 2; }
  [[ -d "$seeds" ]] || { echo "fuzz.sh: no seed corpus $seeds" >&2; exit 2; }
  work="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  ((keep)) || rm -rf "$work"
  rm -rf "$artifacts"
  mkdir -p "$work" "$artifacts"
  log="$build/logs/$t.log"
  mkdir -p "$(dirname "$log")"
  start=$(date +%s)
  # -timeout: one input taking longer is a hang (a finding); -rss_limit_mb bounds memory
  # on this shared machine; the seed dir comes second so it is read but never written.
  set +e
  "$exe" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" "$work" "$seeds" >"$log" 2>&1
  rc=$?
  set -e
  elapsed=$(( $(date +%s) - start ))
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
  corpus=$(find "$work" -type f | wc -l)
  crashes=$(find "$artifacts" -type f | wc -l)
  if ((rc == 0 && crashes == 0)); then
    result=ok
  else
    result="FINDING (exit $rc): $(find "$artifacts" -type f | head -3 | tr '\n' ' ') log $log"
    failed=1
  fi
  printf '%-18s %8s %10s %9s %6s %6s  %s\n' "$t" "$elapsed" "${runs:-?}" "${rate:-?}" "${cov:-?}" "$corpus" "$result"
done
if ((failed)); then
  echo "fuzz.sh: findings above; reproduce with DIR/standcal_fuzz_<target> <artifact>, then save the" >&2
  echo "         input under fuzz/regressions/<target>/ (docs/fuzzing.md)" >&2
fi
exit "$failed"
