#!/usr/bin/env bash
# Fails when a test binary under DIR carries Eigen's packet kernels out of line, which only
# a translation unit built at -O0 leaves there: the linker keeps one copy of each Eigen
# template, the first it meets, so a test target whose own code is at -O0 and instantiates
# the matrix kernels makes calib's fits run on them (noise_honesty_tests ran its Monte Carlo
# 3.2x slower so until 2026-12-05). Such a target needs standcal_optimise_maths.
#   tests/check_eigen_kernels.sh BUILD_DIR/tests
set -euo pipefail
dir="$1"
# Their maths is one fit at a run's end; the rest is sockets and processes (perf, 2026-12-05:
# 11 % of daemon_tests' samples in its own code), not worth -O2's compile time.
io_bound='^(daemon_tests|daemon_load_tests)$'
found=0
while IFS= read -r -d '' binary; do
  [[ "$(basename "$binary")" =~ $io_bound ]] && continue
  # Read whole, not piped into grep -q: under pipefail nm's SIGPIPE made every test pass.
  symbols=$(nm -C "$binary" 2>/dev/null || true)
  if grep -Eq ' Eigen::internal::p(add|mul)<' <<<"$symbols"; then
    echo "${binary#"$dir"/}: Eigen's kernels out of line (built at -O0): give its target" \
      "standcal_optimise_maths (CMakeLists.txt)"
    found=1
  fi
done < <(find "$dir" -path '*/CMakeFiles' -prune -o -type f -executable -name '*test*' -print0)
exit "$found"
