#!/usr/bin/env bash
# Runs peis-bench-configurator (deployment, repair, soak: the meta-level's
# runtime with real processes) and writes its tables into docs/performance.md
# between the CONFIGURATOR-RESULTS markers.
set -euo pipefail
build=${1:-build}
trials=${PEIS_BENCH_REPAIR_TRIALS:-100}
cd "$(dirname "$0")/.."
export PEIS_LOG=quiet
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
bench="$build/bench/peis-bench-configurator"
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr), build type RelWithDebInfo, unpinned, load average before: $(cut -d' ' -f1-3 /proc/loadavg)."
  echo
  "$bench" deploy --trials 30
  echo "Repair: $trials trials per row. Detection is kill -> the configurator's failure event; planning and deployment are the durations the configurator measured itself; fresh data is kill -> the first value of the new producer at the consumer."
  echo
  "$bench" repair --trials "$trials" --header
  "$bench" repair --trials "$trials" --liveness-ms 500
  "$bench" repair --trials "$trials" --freeze
  "$bench" repair --trials "$trials" --liveness-ms 500 --freeze
  echo
  echo "Soak: both cores kept busy by the benchmark; the producer frozen (SIGSTOP) for 60 % of the liveness period, then thawed, again and again."
  echo
  "$bench" soak --trials 20 --header
  "$bench" soak --trials 20 --liveness-ms 500
} >"$out"
cat "$out"
bench/splice_results.sh CONFIGURATOR-RESULTS "$out" docs/performance.md
rm -f "$out"
echo "updated docs/performance.md (configurator)"
