#!/usr/bin/env bash
# Runs the recorder benchmark (peis-bench-record: a writer at 100,000
# distinct 16-byte updates/s for 30 s, peis-record recording them) unpinned
# and with the recorder and writer pinned to one core each, and writes the
# table into docs/performance.md between the RECORD markers.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
export PEIS_LOG=quiet
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
record="$build/components/recorder/peis-record"
out=$(mktemp)
header='| load | written | written /s | recorded | missing | coalesced (seqno gaps / writer) | recorder CPU µs per update | recorder CPU | disk B per update | longest commit | drain after the writer s | recorder max RSS |'
rule='|---|---|---|---|---|---|---|---|---|---|---|---|'
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr), build type RelWithDebInfo, load average $(cut -d" " -f1-3 /proc/loadavg) at the start; the recording in ${TMPDIR:-/tmp}."
  echo
  echo "$header"
  echo "$rule"
  # The target, then beyond it (where the recorder may fall behind: its row
  # shows what was coalesced before it).
  "$build/bench/peis-bench-record" --record "$record" --dir "${TMPDIR:-/tmp}" ||
    echo "(the recorder did not record every update at the target: see the row)"
  "$build/bench/peis-bench-record" --record "$record" --dir "${TMPDIR:-/tmp}" --rate 200000 --seconds 10 || true
} >"$out"
cat "$out"
bench/splice_results.sh RECORD "$out" docs/performance.md
echo "updated docs/performance.md (recorder)"
