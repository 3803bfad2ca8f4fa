#!/usr/bin/env bash
# Builds the four device programs for the LM3S6965 port (Cortex-M3) into
# OUT_DIR and prints one line per program:
#   lm3s6965 lamp flash 12345 ram 1234
# (bytes, from arm-none-eabi-size: flash = .text + .data, ram = .data + .bss).
# The seed's budget (40 KB flash, 4 KB RAM less a stack reserve) is checked
# by the linker (lm3s6965.ld) and again here; any program over it fails the
# build (non-zero exit). The kernel's tables keep the defaults of
# tiny_kernel.h (override with TINY_ARM_DEFS).
set -euo pipefail

OUT_DIR=${1:?usage: build.sh OUT_DIR}
HERE=$(cd "$(dirname "$0")" && pwd)
TINY=$(cd "$HERE/../.." && pwd)
CC=${CC:-arm-none-eabi-gcc}
SIZE=${SIZE:-arm-none-eabi-size}
TARGET=lm3s6965
FLASH_BUDGET=40960 # the seed's 40 KB of flash
RAM_BUDGET=4096    # the seed's 4 KB of RAM (the chip has 64 KB)
STACK_RESERVE=${TINY_STACK_RESERVE:-512}
DEFS=${TINY_ARM_DEFS:-}

CFLAGS=(-std=c99 -Wall -Wextra -Wpedantic -Werror -Os -mcpu=cortex-m3 -mthumb
  -ffunction-sections -fdata-sections -I"$TINY/include" -I"$HERE")
# shellcheck disable=SC2206
CFLAGS+=($DEFS)
LDFLAGS=(-mcpu=cortex-m3 -mthumb -nostartfiles --specs=nano.specs --specs=nosys.specs
  -T "$HERE/lm3s6965.ld" -Wl,--gc-sections -Wl,--defsym=TINY_FLASH_BUDGET=$FLASH_BUDGET
  -Wl,--defsym=TINY_RAM_BUDGET=$RAM_BUDGET -Wl,--defsym=TINY_STACK_RESERVE=$STACK_RESERVE)

SOURCES=("$TINY/src/tiny_tuple.c" "$TINY/src/tiny_kernel.c" "$TINY/src/tiny_mac.c" "$TINY/src/tiny_app.c"
  "$TINY/src/tiny_serial.c" "$HERE/main.c")

# shellcheck source=../build_programs.sh
source "$HERE/../build_programs.sh"
build_programs
