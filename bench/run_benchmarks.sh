#!/usr/bin/env bash
# Runs every benchmark pinned to one core (taskset -c 0) and unpinned, and
# writes the tables into docs/performance.md between the RESULTS markers.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
export PEIS_LOG=quiet
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr), build type RelWithDebInfo."
  echo
  echo "### One PEIS, no network — pinned (taskset -c 0)"
  echo
  taskset -c 0 "$build/bench/peis-bench-local"
  echo
  echo "### One PEIS, no network — unpinned"
  echo
  "$build/bench/peis-bench-local"
  echo
  echo "### The ecology over loopback — pinned (taskset -c 0: every process on core 0)"
  echo
  taskset -c 0 "$build/bench/peis-bench-net" rtt
  taskset -c 0 "$build/bench/peis-bench-net" throughput
  echo "A secured ecology (docs/security.md) beside an open one, interleaved in one run (medians of 3):"
  echo
  taskset -c 0 "$build/bench/peis-bench-net" security
  taskset -c 0 "$build/bench/peis-bench-net" join
  echo "### The ecology over loopback — unpinned"
  echo
  "$build/bench/peis-bench-net" rtt
  "$build/bench/peis-bench-net" throughput
  echo "A secured ecology beside an open one, interleaved in one run (medians of 3):"
  echo
  "$build/bench/peis-bench-net" security
  "$build/bench/peis-bench-net" join
  echo "### Scale — unpinned (N processes on one host; pinning N PEIS to one core measures the scheduler)"
  echo
  "$build/bench/peis-bench-net" scale
} >"$out"
cat "$out"
doc=docs/performance.md
bench/splice_results.sh RESULTS "$out" "$doc"
echo "updated $doc"
