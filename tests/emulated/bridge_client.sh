#!/usr/bin/env bash
# A client for run_emulated.sh: the real bridge on the emulated node's UART
# and a full PEIS that sets the node's input tuple, then the node's state
# read back through its proxy PEIS. For the lamp (the defaults): full PEIS
# 6890 sets LightValue = 100 and 7.LampLevel must become 100.
#
#   bridge_client.sh SOCKET PEIS_TINYBRIDGE PEIS KEYS.yaml \
#                    [SOURCE IN_KEY NODE OUT_KEY VALUE]
#   e.g. blind: ... 3 TiltValue 4 BlindPosition 0
#
# BRIDGE_OPTIONS: more options for the bridge (e.g. --radio-keys FILE).
# Everything runs in an ecology of its own (discovery stays on loopback);
# the processes it starts are stopped by pid. Exit 0 on success.
set -u
if [ $# -lt 4 ]; then
  echo "usage: bridge_client.sh SOCKET PEIS_TINYBRIDGE PEIS KEYS.yaml [SOURCE IN_KEY NODE OUT_KEY VALUE]" >&2
  exit 2
fi
sock=$1 bridge=$2 peis=$3 keys=$4
source_id=${5:-6890} in_key=${6:-LightValue} node=${7:-7} out_key=${8:-LampLevel} value=${9:-100}
export PEIS_DISCOVERY_SCOPE=${PEIS_DISCOVERY_SCOPE:-loopback}
eco=emulated-$$-$RANDOM
dir=$(mktemp -d "${TMPDIR:-/tmp}/peis-emu-bridge.XXXXXX") || exit 1
pids=()

# shellcheck disable=SC2317 # (run by the EXIT trap)
finish() {
  local status=$? pid
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
  if [ "$status" -ne 0 ]; then
    echo "---- bridge log ----"; tail -n 40 "$dir/bridge.log"
    echo "---- full PEIS $source_id log ----"; tail -n 20 "$dir/full.log"
  fi
  rm -rf "$dir"
  exit "$status"
}
trap finish EXIT
trap 'exit 143' TERM

# shellcheck disable=SC2086 # BRIDGE_OPTIONS is a list of words
"$bridge" --link "unix:$sock" --keys "$keys" --registry "$dir/keys.sqlite" \
  --peis-ecology "$eco" ${BRIDGE_OPTIONS:-} >"$dir/bridge.log" 2>&1 &
pids+=($!)
"$peis" node --peis-id "$source_id" --peis-ecology "$eco" >"$dir/full.log" 2>&1 &
pids+=($!)

step() { # step WHAT COMMAND...: run one peis command, fail with WHAT
  local what=$1 out
  shift
  if ! out=$("$@" --peis-ecology "$eco" 2>>"$dir/cli.log"); then
    echo "FAIL: $what"
    exit 1
  fi
  printf '%s' "$out"
}
echo "node $node joined: $(step "node $node's proxy did not appear" "$peis" get "$node.kernel.name" --wait 20)"
step "full PEIS could not set $source_id.$in_key" "$peis" set "$source_id.$in_key" "$value" --timeout 15
echo "$source_id.$in_key = $value set"
# The node publishes its state after the value reached it: wait for it.
deadline=$((SECONDS + 20))
while :; do
  got=$("$peis" get "$node.$out_key" --wait 5 --peis-ecology "$eco" 2>>"$dir/cli.log")
  [ "$got" = "$value" ] && break
  if [ $SECONDS -ge $deadline ]; then
    echo "FAIL: $node.$out_key is '${got}', expected '$value'"
    exit 1
  fi
done
echo "PASS: $node.$out_key = $got through the bridge"
