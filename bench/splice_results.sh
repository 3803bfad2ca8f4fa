#!/usr/bin/env bash
# Replaces what lies between the markers <!-- NAME:BEGIN --> and
# <!-- NAME:END --> of a document with the contents of a file (awk: no
# Python needed). Used by the benchmark scripts for docs/performance.md.
#
#   splice_results.sh NAME RESULTS_FILE DOCUMENT
set -euo pipefail
name=$1 results=$2 doc=$3
grep -q "<!-- $name:BEGIN -->" "$doc" && grep -q "<!-- $name:END -->" "$doc" ||
  { echo "$doc lacks the $name markers" >&2; exit 1; }
awk -v results="$results" -v begin="<!-- $name:BEGIN -->" -v end="<!-- $name:END -->" '
  $0 == begin { print; while ((getline line < results) > 0) print line; skip = 1; next }
  $0 == end { skip = 0 }
  !skip { print }
' "$doc" >"$doc.new" && mv "$doc.new" "$doc"
