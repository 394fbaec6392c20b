#!/usr/bin/env bash
# The 30-minute soak (docs/reliability.md): back-to-back simulated runs against a real
# standcald, RSS and open fds sampled, verdict flat / not flat (exit 2 when not).
#   scripts/soak.sh [standcal-bench-soak options]   default: --minutes 30 --trim-at-end
# Not part of CI. Installs gdb (--trim-at-end calls malloc_trim in the daemon through it)
# and valgrind (--daemon-wrapper "valgrind --tool=massif" for a heap profile).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/setup.sh" gdb valgrind
"$root/scripts/build.sh" release
cmake --build "$root/build/release" --target standcal-bench-soak
# A copy of the daemon, so rebuilding the tree during the soak cannot change it.
copy="$(mktemp -d)"
trap 'rm -rf "$copy"' EXIT
cp "$root/build/release/daemon/standcald/standcald" "$copy/"
args=("$@")
if [ ${#args[@]} -eq 0 ]; then args=(--minutes 30 --trim-at-end); fi
"$root/build/release/bench/soak/standcal-bench-soak" --daemon "$copy/standcald" "${args[@]}"
