#!/usr/bin/env bash
# Fuzzes a decoder with libFuzzer for a bounded time.
#
#   tests/fuzz/run_fuzz.sh BUILD_DIR [wire|tiny|secured]
#
# wire (default): compiles tests/fuzz/wire_fuzz.cpp with clang++
# (-fsanitize=fuzzer,address,undefined) into BUILD_DIR/fuzz/ and writes a
# seed corpus of valid frames with tests/fuzz/write_seeds.cpp. tiny: compiles
# tiny/fuzz/tiny_decode_fuzz.c (the Tiny PEIS-kernel's radio-frame decoder)
# into BUILD_DIR/fuzz-tiny/, starting from an empty corpus. secured: compiles
# tests/fuzz/secured_fuzz.cpp (a secured link's auth field, identities and
# records, through the security module: libsodium and libgcrypt) into
# BUILD_DIR/fuzz-secured/. Each then runs
# the fuzzer for PEIS_FUZZ_SECONDS
# (default 20). Exits non-zero when the fuzzer finds a crash, a leak or a
# sanitizer error (the input is kept as BUILD_DIR/fuzz/crash-*), and 0 with
# a note when clang++ or libFuzzer is missing (Debian 12: packages clang and
# libclang-rt-14-dev, which ./run installs).
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:?usage: run_fuzz.sh BUILD_DIR [wire|tiny|secured]}
target=${2:-wire}
case "$target" in wire | tiny | secured) ;; *) echo "unknown fuzz target '$target'" >&2; exit 2 ;; esac
mkdir -p "$build"
build=$(cd "$build" && pwd)
out="$build/fuzz"
[ "$target" = tiny ] && out="$build/fuzz-tiny"
[ "$target" = secured ] && out="$build/fuzz-secured"
seconds=${PEIS_FUZZ_SECONDS:-20}

skip() {
  echo "SKIP: wire fuzzing skipped: $*"
  exit 77  # CTest reports it as skipped (SKIP_RETURN_CODE)
}

cxx=${PEIS_FUZZ_CXX:-}
if [ -z "$cxx" ]; then
  for candidate in clang++ clang++-14 clang++-15 clang++-16 clang++-17 clang++-18; do
    if command -v "$candidate" >/dev/null 2>&1; then
      cxx=$candidate
      break
    fi
  done
fi
[ -n "$cxx" ] || skip "no clang++ found (install clang)"

mkdir -p "$out"
# Can this compiler link a libFuzzer target at all?
probe="$out/probe.cpp"
cat >"$probe" <<'PROBE'
#include <cstddef>
#include <cstdint>
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t*, std::size_t) { return 0; }
PROBE
if ! "$cxx" -fsanitize=fuzzer,address,undefined "$probe" -o "$out/probe" >"$out/probe.log" 2>&1; then
  cat "$out/probe.log"
  skip "$cxx cannot link -fsanitize=fuzzer (install libclang-rt-14-dev or your clang's libFuzzer)"
fi

rm -rf "$out/seeds" "$out/corpus"
mkdir -p "$out/seeds" "$out/corpus"
sanitize=(-fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
if [ "$target" = wire ]; then
  flags=(-std=c++20 -O1 -g -I "$root/kernel/include" -I "$root/kernel/src")
  sources=("$root/kernel/src/net/wire.cpp" "$root/kernel/src/key.cpp")
  echo "==> compiling the wire fuzzer with $cxx"
  "$cxx" "${flags[@]}" "${sanitize[@]}" "$root/tests/fuzz/wire_fuzz.cpp" "${sources[@]}" \
    -o "$out/fuzzer"
  "$cxx" "${flags[@]}" "$root/tests/fuzz/write_seeds.cpp" "${sources[@]}" -o "$out/write_seeds"
  "$out/write_seeds" "$out/seeds"
elif [ "$target" = secured ]; then
  # The cryptography is the security module's, which the kernel's loader
  # (backend_loader.cpp) opens: the one this build made, of its version.
  module=$(find "$build/.." -path '*/lib/peis/libpeis-security.so' -print -quit)
  version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$build/../CMakeCache.txt")
  [ -n "$module" ] && [ -n "$version" ] || skip "no security module (lib/peis/libpeis-security.so) in $build/.."
  export PEIS_SECURITY_MODULE=$module
  flags=(-std=c++20 -O1 -g -I "$root/kernel/include" -I "$root/kernel/src"
    -DPEIS_VERSION="\"$version\"" -DPEIS_SECURITY_MODULE_NAME='"libpeis-security.so"'
    -DPEIS_SECURITY_MODULE_FROM_BIN='"."' -DPEIS_SECURITY_MODULE_BUILD_PATH="\"$module\""
    -DPEIS_SECURITY_MODULE_INSTALL_PATH="\"$module\"")
  sources=("$root/kernel/src/security/certificate.cpp" "$root/kernel/src/security/identity.cpp"
    "$root/kernel/src/security/link_handshake.cpp" "$root/kernel/src/security/record_cipher.cpp"
    "$root/kernel/src/security/crypto.cpp" "$root/kernel/src/security/credentials.cpp"
    "$root/kernel/src/security/yaml_file.cpp" "$root/kernel/src/security/backend_loader.cpp"
    "$root/kernel/src/key.cpp")
  echo "==> compiling the secured-link fuzzer with $cxx"
  "$cxx" "${flags[@]}" "${sanitize[@]}" "$root/tests/fuzz/secured_fuzz.cpp" "${sources[@]}" \
    -o "$out/fuzzer"
else
  cc=${cxx/clang++/clang}
  echo "==> compiling the tiny frame fuzzer with $cc"
  "$cc" -std=c99 -O1 -g -I "$root/tiny/include" "${sanitize[@]}" \
    "$root/tiny/fuzz/tiny_decode_fuzz.c" "$root/tiny/src/tiny_tuple.c" "$root/tiny/src/tiny_mac.c" \
    -o "$out/fuzzer"
fi
rm -f "$out"/crash-* "$out"/leak-* "$out"/timeout-* "$out"/oom-*

echo "==> fuzzing the $target decoder for ${seconds}s"
status=0
# New inputs go to corpus/ (the first directory); the seeds stay as written.
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} \
  "$out/fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
  -print_final_stats=1 -artifact_prefix="$out/" "$out/corpus" "$out/seeds" \
  >"$out/fuzz.log" 2>&1 || status=$?
tail -n 25 "$out/fuzz.log"
if [ "$status" -ne 0 ]; then
  echo "$target fuzzer failed (exit $status); full log: $out/fuzz.log" >&2
  for artifact in "$out"/crash-* "$out"/leak-* "$out"/timeout-* "$out"/oom-*; do
    [ -e "$artifact" ] && echo "reproduce with: $out/fuzzer $artifact" >&2
  done
  exit 1
fi
echo "$target fuzzer: no crash in ${seconds}s"
