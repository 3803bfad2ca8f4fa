#!/usr/bin/env bash
# Builds the four device programs for the MSP430F1611 port (the TelosB's
# MCU) into OUT_DIR and prints one line per program:
#   msp430f1611 lamp flash 12345 ram 1234
# (bytes, from llvm-size: flash = .text + .data + the 32-byte vector table,
# ram = .data + .bss). The seed's budget (40 KB flash, 4 KB RAM less a stack
# reserve) is checked by the linker (msp430f1611.ld) and again here; any
# program over it fails the build (non-zero exit).
#
# The toolchain is clang --target=msp430 with ld.lld, freestanding: no
# MSP430 C library or GCC is needed (Debian has no msp430-elf-gcc); the
# port brings its linker script, startup code, <string.h> and the EABI
# arithmetic helpers (runtime.c). clang 14's MSP430 driver always runs
# msp430-elf-ld to link, so ld.lld is called directly.
#
# Environment: CC (default clang), LD (default ld.lld), SIZE (default
# llvm-size), TINY_STACK_RESERVE (default 512), TINY_MSP430_DEFS (the
# kernel's table sizes; default: those of tiny_kernel.h, as the LM3S6965).
set -euo pipefail

OUT_DIR=${1:?usage: build.sh OUT_DIR}
HERE=$(cd "$(dirname "$0")" && pwd)
TINY=$(cd "$HERE/../.." && pwd)
CC=${CC:-clang}
LINK=${LD:-ld.lld}
SIZE=${SIZE:-llvm-size}
MCU=msp430f1611
TARGET=$MCU
FLASH_BUDGET=40960 # the seed's 40 KB of flash (the chip has 48 KB)
RAM_BUDGET=4096    # the seed's 4 KB of RAM (the chip has 10 KB)
STACK_RESERVE=${TINY_STACK_RESERVE:-512}
DEFS=${TINY_MSP430_DEFS:-}

for tool in "$CC" "$LINK" "$SIZE"; do
  if ! command -v "$tool" >/dev/null; then
    echo "error: $tool not found (the MSP430 port needs clang, lld and llvm)" >&2
    exit 1
  fi
done

CFLAGS=(--target=msp430 -mmcu=$MCU -std=c99 -Wall -Wextra -Wpedantic -Werror -Os
  -ffreestanding -ffunction-sections -fdata-sections -I"$HERE/libc" -I"$TINY/include"
  -I"$HERE")
# shellcheck disable=SC2206
CFLAGS+=($DEFS)
LDFLAGS=(-T "$HERE/msp430f1611.ld" --gc-sections --defsym=TINY_FLASH_BUDGET=$FLASH_BUDGET
  --defsym=TINY_RAM_BUDGET=$RAM_BUDGET --defsym=TINY_STACK_RESERVE=$STACK_RESERVE)

SOURCES=("$TINY/src/tiny_tuple.c" "$TINY/src/tiny_kernel.c" "$TINY/src/tiny_mac.c" "$TINY/src/tiny_app.c"
  "$TINY/src/tiny_serial.c" "$HERE/main.c" "$HERE/runtime.c")

# shellcheck source=../build_programs.sh
source "$HERE/../build_programs.sh"
build_programs
