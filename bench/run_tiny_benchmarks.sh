#!/usr/bin/env bash
# The tinybridge benchmarks: the round trip full PEIS -> bridge -> lamp ->
# back on the host port (simulated medium, pinned and unpinned, beside a UDP
# ping-pong of the same run) and on the emulated LM3S6965 (the lamp firmware
# under qemu-system-arm, its UART on a UNIX socket), and the radio-frame
# efficiency. Writes the table between the TINY-RESULTS markers of
# docs/performance.md.
set -euo pipefail
build=${1:-build}
cd "$(dirname "$0")/.."
export PEIS_LOG=quiet
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
bench=$build/bench/peis-bench-tiny
port=$((21000 + RANDOM % 1000 * 8))
out=$(mktemp)
{
  echo "Measured $(date -u '+%Y-%m-%d %H:%M UTC') on $(nproc) cores, $(uname -sr)."
  echo
  echo "| what | p50 / value | detail |"
  echo "|---|---|---|"
  taskset -c 0 "$bench" roundtrip --link "medium:$port" --rounds 500 --label "host port, pinned" \
    -- "$build/tiny/tiny-lamp"
  "$bench" roundtrip --link "medium:$((port + 8))" --rounds 500 --label "host port, unpinned" \
    -- "$build/tiny/tiny-lamp"
  qemu_lamp=$build/tiny/firmware/arm-lm3s6965-qemu/lamp.elf
  if command -v qemu-system-arm >/dev/null && [ -f "$qemu_lamp" ]; then
    sock=$(mktemp -u /tmp/peis-bench-qemu-XXXXXX.sock)
    "$bench" roundtrip --link "unix:$sock" --rounds 100 \
      --label "LM3S6965 under qemu-system-arm, UART on a UNIX socket" \
      -- timeout 300 qemu-system-arm -M lm3s6965evb -nographic -monitor none \
      -semihosting-config enable=on,target=native -kernel "$qemu_lamp" \
      -serial "unix:$sock,server=on,wait=off"
    rm -f "$sock"
  else
    echo "| round trip on the emulated LM3S6965 | - | skipped: qemu-system-arm or $qemu_lamp missing |"
  fi
  echo
  echo "Radio-frame efficiency (one sub-key; every tuple fits one frame of at most 100 bytes):"
  echo
  "$bench" frames
} >"$out"
cat "$out"
doc=docs/performance.md
bench/splice_results.sh TINY-RESULTS "$out" "$doc"
rm -f "$out"
echo "updated $doc (tinybridge)"
