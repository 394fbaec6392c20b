#!/usr/bin/env bash
# The whole test suite: a Release build and an AddressSanitizer+UBSan build, warnings as
# errors in both, every test in both. Slower checks (TSan, fuzzing) are separate scripts.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
for flavour in release asan; do
  echo "=== $flavour build ===" >&2
  "$root/scripts/build.sh" "$flavour"
  echo "=== $flavour tests ===" >&2
  ctest --test-dir "$root/build/$flavour" --output-on-failure -j "$(nproc)" --timeout 600
done
