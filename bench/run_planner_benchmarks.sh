#!/usr/bin/env bash
# Runs peis-bench-planner (the configuration and task planners) and writes its
# tables into docs/performance.md between the PLANNER-RESULTS markers.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr), build type RelWithDebInfo, unpinned."
  echo
  "$build/bench/peis-bench-planner" --time-limit 1000
} >"$out"
cat "$out"
doc=docs/performance.md
grep -q '<!-- PLANNER-RESULTS:BEGIN -->' "$doc" && grep -q '<!-- PLANNER-RESULTS:END -->' "$doc" ||
  { echo "docs/performance.md lacks the PLANNER-RESULTS markers" >&2; exit 1; }
awk -v results="$out" '
  /<!-- PLANNER-RESULTS:BEGIN -->/ { print; while ((getline line < results) > 0) print line; skip = 1; next }
  /<!-- PLANNER-RESULTS:END -->/ { skip = 0 }
  !skip { print }
' "$doc" >"$doc.new" && mv "$doc.new" "$doc"
rm -f "$out"
echo "updated $doc (planners)"
