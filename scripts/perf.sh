#!/usr/bin/env bash
# The offline performance figures of docs/performance.md: installs the numpy reference's
# package (python3-numpy) through setup.sh, builds the Release benches, runs bench_fit
# (fit, diagnose and noise as a user runs them, beside wc -l and numpy).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/setup.sh" python3-numpy
"$root/scripts/build.sh" release
cmake --build "$root/build/release" --target bench_fit
exec "$root/build/release/bench/fit/bench_fit" "$@"
