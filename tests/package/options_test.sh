#!/usr/bin/env bash
# The build options leave their parts out (docs/packaging.md): configured
# with PEIS_BUILD_TESTS, PEIS_BUILD_BENCH and PEIS_BUILD_TINY off, the build
# still defines the libraries and programs that are installed, and none of
# the tests, benchmarks or tiny device programs; tests without the tiny
# programs are refused with a clear message. Configures only (no build).
#
#   options_test.sh SOURCE_DIR WORK_DIR GENERATOR
set -euo pipefail
source=$1 work=$2 generator=$3

fail() {
  printf 'options test: %s\n' "$*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work"
cmake -S "$source" -B "$work/lean" -G "$generator" -DPEIS_BUILD_TESTS=OFF -DPEIS_BUILD_BENCH=OFF \
  -DPEIS_BUILD_TINY=OFF >"$work/lean.log" 2>&1 || {
  cat "$work/lean.log"
  fail "the build with every option off did not configure"
}
targets=$(cmake --build "$work/lean" --target help)
has() { grep -Eq "(^|[ /])$1(:| |$)" <<<"$targets"; }
for wanted in peis_kernel peis_component peis peis-tinybridge peis-example-lamp install; do
  has "$wanted" || fail "without tests, benchmarks and tiny programs, '$wanted' is missing"
done
for unwanted in peis_kernel_tests peis-layering-check peis-bench-local tiny-lamp tiny-plant \
  simavr_uart_socket; do
  has "$unwanted" && fail "'$unwanted' is built although its option is off"
done
[ -f "$work/lean/CTestTestfile.cmake" ] && fail "CTest is on although PEIS_BUILD_TESTS is off"
echo "every option off: the libraries and programs only"

if cmake -S "$source" -B "$work/refused" -G "$generator" -DPEIS_BUILD_TINY=OFF \
  >"$work/refused.log" 2>&1; then
  fail "tests without the tiny device programs were accepted"
fi
grep -q 'PEIS_BUILD_TINY' "$work/refused.log" || {
  cat "$work/refused.log"
  fail "the refusal does not name PEIS_BUILD_TINY"
}
echo "tests without the tiny programs: refused"
rm -rf "$work"
