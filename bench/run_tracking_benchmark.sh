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
grep -q '<!-- TRACKING-RESULTS:BEGIN -->' "$doc" && grep -q '<!-- TRACKING-RESULTS:END -->' "$doc" ||
  { echo "docs/performance.md lacks the TRACKING-RESULTS markers" >&2; exit 1; }
awk -v results="$out" '
  /<!-- TRACKING-RESULTS:BEGIN -->/ { print; while ((getline line < results) > 0) print line; skip = 1; next }
  /<!-- TRACKING-RESULTS:END -->/ { skip = 0 }
  !skip { print }
' "$doc" >"$doc.new" && mv "$doc.new" "$doc"
rm -f "$out"
echo "updated $doc"
