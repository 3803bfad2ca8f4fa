#!/usr/bin/env bash
# Runs the navigation benchmark pinned to one core and writes its tables into
# docs/performance.md between the NAVIGATION markers.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), pinned (taskset -c 0), build type RelWithDebInfo."
  echo
  taskset -c 0 "$build/bench/peis-bench-navigation"
} >"$out"
cat "$out"
doc=docs/performance.md
grep -q '<!-- NAVIGATION:BEGIN -->' "$doc" && grep -q '<!-- NAVIGATION:END -->' "$doc" ||
  { echo "docs/performance.md lacks the NAVIGATION markers" >&2; exit 1; }
awk -v results="$out" '
  /<!-- NAVIGATION:BEGIN -->/ { print; while ((getline line < results) > 0) print line; skip = 1; next }
  /<!-- NAVIGATION:END -->/ { skip = 0 }
  !skip { print }
' "$doc" >"$doc.new" && mv "$doc.new" "$doc"
echo "updated $doc (navigation)"
