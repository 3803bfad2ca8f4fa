#!/usr/bin/env bash
# Camera tracking: accuracy against the simulation's ground truth and time
# per 640x480 frame on one core (taskset -c 0). Writes the table between the
# TRACKING-RESULTS markers of docs/performance.md.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr), build type RelWithDebInfo, pinned (taskset -c 0)."
  echo
  taskset -c 0 "$build/bench/peis-bench-tracking" --poses 300
} >"$out"
cat "$out"
doc=docs/performance.md
bench/splice_results.sh TRACKING-RESULTS "$out" "$doc"
rm -f "$out"
echo "updated $doc"
