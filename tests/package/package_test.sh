#!/usr/bin/env bash
# The installed package as an outside project uses it (docs/packaging.md):
#   1. `cmake --install` of this build into a fresh prefix;
#   2. every installed header compiles alone against that prefix only, and a
#      header that includes something not installed is caught (checked by
#      planting one in a copy of the prefix);
#   3. components/examples/ builds as a separate CMake project with
#      find_package(peis), and lamp.cpp builds with pkg-config alone;
#   4. both programs answer --help; the CMake-built lamp joins an ecology, and
#      the installed `peis` tool reads its status, drives its actuator and
#      makes it quit.
#
#   package_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX_COMPILER GENERATOR
set -euo pipefail
build=$1 source=$2 work=$3 cxx=$4 generator=$5

step() { printf '== [%3ss] %s\n' "$SECONDS" "$*"; }
fail() {
  printf 'package test: %s\n' "$*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix

step "install $build into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log" || {
  cat "$work/install.log"
  fail "cmake --install failed"
}
for path in bin/peis include/peis/kernel.h include/peis/component.h include/peis/conventions.h; do
  [ -e "$prefix/$path" ] || fail "$path was not installed"
done
config=$(find "$prefix" -name peisConfig.cmake -print -quit)
version=$(find "$prefix" -name peisConfigVersion.cmake -print -quit)
pc_dir=$(dirname "$(find "$prefix" -name peis-component.pc -print -quit)")
[ -n "$config" ] && [ -n "$version" ] || fail "no CMake package files in $prefix"
[ -f "$pc_dir/peis-kernel.pc" ] || fail "no pkg-config files in $prefix"
if grep -rIl -e "$source" -e "$build" "$prefix" --include='*.cmake' --include='*.pc' >/dev/null; then
  fail "an installed package file names the source or build tree"
fi

# configure SOURCE BINARY PREFIX [cmake args...]: a project that finds peis
# in PREFIX only.
configure() {
  local src=$1 bin=$2 in=$3
  shift 3
  cmake -S "$src" -B "$bin" -G "$generator" -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DCMAKE_PREFIX_PATH="$in" \
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF "$@"
}
# ccache (as the main build uses it) only saves time: it compiles the same.
launcher=$(command -v ccache || true)

step "every installed header compiles alone against the installed tree"
configure "$source/tests/package/headers" "$work/headers" "$prefix" -DPEIS_EXPECTED_PREFIX="$prefix" \
  >"$work/headers.log" 2>&1 || {
  cat "$work/headers.log"
  fail "the header check did not configure"
}
cmake --build "$work/headers" >>"$work/headers.log" 2>&1 || {
  cat "$work/headers.log"
  fail "an installed header does not compile alone"
}
grep 'checking .* installed headers' "$work/headers.log"

step "the header check catches a header that includes something not installed"
cp -a "$prefix" "$work/broken"
printf '#pragma once\n#include "tuple_space.h"\n' >"$work/broken/include/peis/leaky.h"
if configure "$source/tests/package/headers" "$work/headers-broken" "$work/broken" \
  -DPEIS_EXPECTED_PREFIX="$work/broken" \
  >"$work/broken.log" 2>&1 && cmake --build "$work/headers-broken" >>"$work/broken.log" 2>&1; then
  fail "a header including the kernel's tuple_space.h compiled against the installed tree"
fi
grep -q 'tuple_space.h' "$work/broken.log" || {
  cat "$work/broken.log"
  fail "the broken header failed, but not for its include"
}
rm -rf "$work/broken"

step "components/examples/ as a standalone CMake project"
configure "$source/components/examples" "$work/examples" "$prefix" >"$work/examples.log" 2>&1 || {
  cat "$work/examples.log"
  fail "components/examples/ did not configure against the installed package"
}
found=$(sed -n 's/^peis_DIR:PATH=//p' "$work/examples/CMakeCache.txt")
case "$found" in
  "$prefix"/*) echo "find_package(peis) used $found" ;;
  *) fail "find_package(peis) found '$found', not the package in $prefix" ;;
esac
cmake --build "$work/examples" >>"$work/examples.log" 2>&1 || {
  cat "$work/examples.log"
  fail "components/examples/ did not build against the installed package"
}
lamp=$work/examples/peis-example-lamp

step "lamp.cpp built with pkg-config"
export PKG_CONFIG_PATH=$pc_dir
flags=$(pkg-config --cflags --libs peis-component) || fail "pkg-config does not know peis-component"
# A shared build (BUILD_SHARED_LIBS=ON): the program finds the libraries by
# its run path, as a packaged one would by the system's library path.
if [ -n "$(find "$prefix" -name 'libpeis-kernel.so*' -print -quit)" ]; then
  flags="$flags -Wl,-rpath,$(pkg-config --variable=libdir peis-kernel)"
fi
echo "pkg-config --cflags --libs peis-component: $flags"
# shellcheck disable=SC2086  # the flags are words
$launcher "$cxx" -std=c++20 "$source/components/examples/lamp.cpp" $flags -o "$work/lamp-pkgconfig" ||
  fail "lamp.cpp did not build with pkg-config's flags"

step "both programs answer --help"
for program in "$lamp" "$work/lamp-pkgconfig"; do
  help=$("$program" --help) || fail "$program --help exited $?"
  grep -q -- '--peis-id' <<<"$help" || fail "$program --help does not list --peis-id"
done

step "every installed program answers --help once and refuses an unknown option"
for program in "$prefix"/bin/*; do
  help=$("$program" --help 2>&1) || fail "$program --help exited $?"
  [ "$(grep -c '^PEIS options:' <<<"$help")" -le 1 ] || fail "$program --help lists its PEIS options twice"
  status=0
  "$program" --no-such-option >/dev/null 2>&1 </dev/null || status=$?
  [ "$status" -eq 2 ] || fail "$program --no-such-option exited $status, not 2"
done

step "the lamp in an ecology, driven by the installed peis tool"
peis=$prefix/bin/peis
ecology=package-$$-$RANDOM
lamp_id=$((20000 + RANDOM % 10000))
common=(--peis-ecology "$ecology")
"$lamp" --peis-id "$lamp_id" --peis-name lamp "${common[@]}" >"$work/lamp.out" 2>"$work/lamp.err" &
lamp_pid=$!
trap 'kill "$lamp_pid" 2>/dev/null || true' EXIT

# get_until KEY VALUE: reads OWNER.KEY with the installed tool until it shows
# VALUE (the tuple may still hold an earlier value), for at most 60 s.
get_until() {
  local key=$1 want=$2 got="" deadline=$((SECONDS + 60))
  while [ $SECONDS -lt $deadline ]; do
    got=$("$peis" get "$lamp_id.$key" --wait 10 "${common[@]}" 2>>"$work/peis.err") || true
    if [ "$got" = "$want" ]; then
      echo "$lamp_id.$key = $got"
      return 0
    fi
    kill -0 "$lamp_pid" 2>/dev/null || fail "the lamp exited early: $(cat "$work/lamp.err")"
  done
  fail "$lamp_id.$key is '$got', not '$want', after 60 s"
}

get_until status waiting
get_until cause.names brightness
"$peis" set "$lamp_id.light.reqState" on --timeout 30 "${common[@]}" 2>>"$work/peis.err" ||
  fail "peis set $lamp_id.light.reqState on failed: $(tail -3 "$work/peis.err")"
get_until light.currState on
grep -q 'light -> on' "$work/lamp.out" || fail "the lamp's actuator did not run"

"$peis" set "$lamp_id.kernel.do-quit" yes --timeout 30 "${common[@]}" 2>>"$work/peis.err" ||
  fail "peis set $lamp_id.kernel.do-quit yes failed: $(tail -3 "$work/peis.err")"
deadline=$((SECONDS + 30))
while kill -0 "$lamp_pid" 2>/dev/null && [ $SECONDS -lt $deadline ]; do
  sleep 0.1 # polling the condition (has it exited?) with a deadline
done
kill -0 "$lamp_pid" 2>/dev/null && fail "the lamp did not quit on kernel.do-quit within 30 s"
status=0
wait "$lamp_pid" || status=$?
trap - EXIT
[ "$status" -eq 0 ] || fail "the lamp exited $status"
echo "the installed package builds and runs a component"
