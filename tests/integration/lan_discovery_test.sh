#!/usr/bin/env bash
# LAN discovery across hosts: two network namespaces joined by a veth pair
# that this test creates (so the traffic never leaves this machine). A PEIS
# in one namespace publishes a tuple; `peis get` in the other finds it with
# no flags but the ecology name: discovery by broadcast on the shared LAN.
# Needs root and iproute2; exits 77 (skipped) otherwise.
set -u
PEIS=${1:?usage: lan_discovery_test.sh PATH_TO_peis}
if [ "$(id -u)" -ne 0 ] || ! command -v ip >/dev/null; then
  echo "SKIP: needs root and iproute2 (ip) to create network namespaces"
  exit 77
fi
tag="p$$"
nsa="peis-a-$tag" nsb="peis-b-$tag" va="pa$tag" vb="pb$tag"
subnet=$(( ($$ % 200) + 20 ))
node_pid=""
cleanup() {
  [ -n "$node_pid" ] && kill "$node_pid" 2>/dev/null && wait "$node_pid" 2>/dev/null
  ip netns del "$nsa" 2>/dev/null
  ip netns del "$nsb" 2>/dev/null
}
trap cleanup EXIT
ip netns add "$nsa" && ip netns add "$nsb" || { echo "SKIP: cannot create namespaces"; exit 77; }
ip link add "$va" type veth peer name "$vb" || { echo "SKIP: cannot create a veth pair"; exit 77; }
ip link set "$va" netns "$nsa"
ip link set "$vb" netns "$nsb"
ip -n "$nsa" addr add "10.213.$subnet.1/24" brd + dev "$va"
ip -n "$nsb" addr add "10.213.$subnet.2/24" brd + dev "$vb"
for ns in "$nsa" "$nsb"; do ip -n "$ns" link set lo up; done
ip -n "$nsa" link set "$va" up
ip -n "$nsb" link set "$vb" up

ecology="lan-$tag"
log=$(mktemp)
ip netns exec "$nsa" env -u PEIS_DISCOVERY_SCOPE "$PEIS" node --peis-id 11 --peis-name host-a \
  --peis-ecology "$ecology" --peis-set-tuple where=host-a >"$log" 2>&1 &
node_pid=$!
# `peis get --wait` is the deadline: it returns as soon as the value arrives.
value=$(ip netns exec "$nsb" env -u PEIS_DISCOVERY_SCOPE "$PEIS" get 11.where --wait 15 \
  --peis-ecology "$ecology" 2>>"$log")
status=$?
if [ $status -ne 0 ] || [ "$value" != "host-a" ]; then
  echo "FAIL: peis get in $nsb returned status $status, value '$value'"
  cat "$log"
  exit 1
fi
echo "PASS: a PEIS in $nsb found 11.where = $value in $nsa by LAN discovery"
