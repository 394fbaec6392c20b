#!/usr/bin/env bash
# The main job: a full calibration on the simulated stand, printing the report.
# Starts standcald on the simulated backend at 300x real time, runs the paper's
# 9-position programme through its socket with the operator CLI, waits for the result
# and prints the report; the daemon is stopped (SIGTERM: axes stopped and disabled).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/build.sh" release >&2
bin="$root/build/release"
work="${STANDCAL_DEMO_DIR:-$root/build/demo}"
rm -rf "$work/state"
mkdir -p "$work/state"
socket="$work/standcald.sock"
"$bin/daemon/standcald/standcald" --sim --socket "$socket" --state-dir "$work/state" \
  --time-scale 300 --log-level warn &
daemon=$!
trap 'kill -TERM "$daemon" 2>/dev/null; wait "$daemon" 2>/dev/null || true' EXIT
for _ in $(seq 100); do [ -S "$socket" ] && break; sleep 0.1; done
"$bin/tools/standcal/standcal" run start paper9 --unit-serial AU-DEMO --wait --socket "$socket"
