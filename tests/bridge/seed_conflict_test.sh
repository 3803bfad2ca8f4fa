#!/usr/bin/env bash
# A registry seeded with LightValue = 42 refuses, at the next start, a seed
# that gives LightValue another index: an index never changes once given.
# Usage: seed_conflict_test.sh BRIDGE SOURCE_DIR
set -u
bridge=$1 source=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
# First start: the seed goes into the registry (the bad link then stops it).
"$bridge" --link bogus --keys "$source/bridge/keys.yaml" --registry "$dir/keys.sqlite" 2>/dev/null
err=$("$bridge" --link medium:29990 --keys "$source/tests/bridge/conflicting_seed.yaml" \
  --registry "$dir/keys.sqlite" --peis-no-discovery 2>&1)
status=$?
if [ "$status" -ne 1 ]; then echo "expected exit 1, got $status: $err"; exit 1; fi
case $err in
  *"gives 'LightValue' index 50 but the registry gave it 42 (an index never changes)"*)
    echo "refused as expected: $err" ;;
  *) echo "unexpected error: $err"; exit 1 ;;
esac
