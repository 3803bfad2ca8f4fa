#!/usr/bin/env bash
# The side-by-side comparison: PEIS beside a one-write raw-TCP ping-pong,
# Cyclone DDS and ZeroMQ, measured in one run, the systems interleaved (every
# repetition runs each system once per size, in turn), pinned to one core and
# unpinned; then the median and the spread (min–max) of the repetitions, and
# PEIS's ratio to each peer. Also the scale figures (200 processes) as medians.
# Writes the tables into docs/performance.md between the PEERS markers.
# PEIS_BENCH_REPS (default 3) sets the repetitions; PEIS_BENCH_SCALE_REPS
# (default 3) those of the 200-process run (0 leaves it out).
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
export PEIS_LOG=quiet
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
reps=${PEIS_BENCH_REPS:-3}
scale_reps=${PEIS_BENCH_SCALE_REPS:-3}
net="$build/bench/peis-bench-net"
peers="$build/bench/peis-bench-peers"
if [ ! -x "$peers" ]; then
  echo "run_peer_comparison: $peers is missing (needs cyclonedds-dev, cyclonedds-tools, libzmq3-dev;" >&2
  echo "  ./run bench installs them and reconfigures)" >&2
  exit 1
fi
raw=$(mktemp)
trap 'rm -f "$raw"' EXIT

# measure KIND SYSTEM SIZE PIN: one measurement, appended to $raw as
# "KIND PIN SIZE SYSTEM numbers...". A failed one is logged and left out.
measure() {
  local kind=$1 system=$2 size=$3 pin=$4 program what numbers
  case $system in
    tcp | peis) program=$net what=once ;;
    *) program=$peers what=once ;;
  esac
  local prefix=()
  [ "$pin" = pinned ] && prefix=(taskset -c 0)
  if numbers=$(timeout 120 "${prefix[@]}" "$program" "$what" "$system-$kind" "$size" 2>/dev/null); then
    echo "$kind $pin $size $system $numbers" >>"$raw"
  else
    echo "run_peer_comparison: $system $kind $size ($pin) failed" >&2
  fi
}

for pin in pinned unpinned; do
  for rep in $(seq "$reps"); do
    echo "round trips, $pin, repetition $rep of $reps" >&2
    for size in 16 1024 65536; do
      for system in tcp peis dds zmq; do measure rtt "$system" "$size" "$pin"; done
    done
    echo "streams, $pin, repetition $rep of $reps" >&2
    for size in 16 1024; do
      for system in peis dds zmq; do measure stream "$system" "$size" "$pin"; done
    done
  done
done
if [ "$scale_reps" -gt 0 ]; then
  for rep in $(seq "$scale_reps"); do
    echo "scale 200, repetition $rep of $scale_reps" >&2
    if numbers=$(timeout 300 "$net" once scale 200 2>/dev/null); then
      echo "scale unpinned 200 peis $numbers" >>"$raw"
    fi
  done
fi

out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')), $(uname -sr); $reps repetitions, the systems interleaved; each cell is the median of the repetitions' values and, in brackets, their range. Cyclone DDS $(dpkg-query -W -f='${Version}' cyclonedds-dev 2>/dev/null || echo '?'), ZeroMQ $(dpkg-query -W -f='${Version}' libzmq3-dev 2>/dev/null || echo '?')."
  echo
  bench/tabulate_peers.awk "$raw"
} >"$out"
cat "$out"
bench/splice_results.sh PEERS "$out" docs/performance.md
echo "updated docs/performance.md"
