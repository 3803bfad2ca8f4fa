#!/usr/bin/env bash
# A secured radio (docs/security.md) on an emulated ATmega128 node: `peis
# keys radio NODE` makes the keys, the node's EEPROM gets its key and the
# bridge's (the layout in tiny/ports/avr/main.c), and run_emulated.sh runs
# the firmware with that EEPROM and bridge_client.sh with the bridge on
# --radio-keys. The bridge drops unsecured frames and the node takes only
# the bridge's, so the client passes only if both sides seal and check.
#
#   secured_radio.sh PEIS NODE RUN_EMULATED [run_emulated.sh's arguments]
set -u
if [ $# -lt 4 ]; then
  echo "usage: secured_radio.sh PEIS NODE RUN_EMULATED ARGS..." >&2
  exit 2
fi
peis=$1 node=$2 run=$3
shift 3
dir=$(mktemp -d "${TMPDIR:-/tmp}/peis-emu-keys.XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT

if ! "$peis" keys radio "$node" --dir "$dir" >"$dir/keys.txt"; then
  echo "FAIL: peis keys radio $node"
  exit 1
fi
# "  node 7: TINY_KEY=<32 hex> TINY_TRUST=65534:<32 hex>:w"
line=$(grep "node $node:" "$dir/keys.txt")
node_key=${line#*TINY_KEY=}
node_key=${node_key%% *}
trust=${line#*TINY_TRUST=}
bridge_id=${trust%%:*}
bridge_key=${trust#*:}
bridge_key=${bridge_key%%:*}
if [ ${#node_key} -ne 32 ] || [ ${#bridge_key} -ne 32 ]; then
  echo "FAIL: unexpected keys: $line"
  exit 1
fi

bytes() { # bytes HEX: the bytes HEX spells
  local hex=$1 out="" i
  for ((i = 0; i < ${#hex}; i += 2)); do out+="\\x${hex:i:2}"; done
  printf '%b' "$out"
}
# magic 'PS', the node's key, the bridge's id (little-endian) and key, the
# frame counter (erased: 0), two peer slots (none: id 0xFFFF).
{
  printf 'PS'
  bytes "$node_key"
  bytes "$(printf '%02x%02x' $((bridge_id & 255)) $((bridge_id >> 8)))"
  bytes "$bridge_key"
  bytes ffffffff
  bytes "$(printf 'ff%.0s' $(seq 36))"
} >"$dir/eeprom.bin"

export BRIDGE_OPTIONS="--radio-keys $dir/radio.yaml"
"$run" --eeprom "$dir/eeprom.bin" "$@"
