#!/usr/bin/env bash
# The main job: a full calibration on the simulated stand, printing the report.
# Simulates the paper's 9-position programme (seeded, so the run is reproducible) into
# a recording and fits it with the joint invariant estimator.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/build.sh" release >&2
out="${STANDCAL_DEMO_DIR:-$root/build/demo}"
mkdir -p "$out"
standcal="$root/build/release/tools/standcal/standcal"
"$standcal" simulate --program paper9 --seed 42 --unit-serial AU-DEMO \
  -o "$out/paper9.csv" --truth "$out/paper9-truth.json"
"$standcal" fit "$out/paper9.csv" --compensation "$out/paper9-compensation"
