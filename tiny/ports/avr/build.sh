#!/usr/bin/env bash
# Builds the four device programs for the ATmega128 port into OUT_DIR and
# prints one line per program:
#   atmega128 lamp flash 12345 ram 1234
# (bytes, from avr-size: flash = .text + .data, ram = .data + .bss).
# The seed's budget (40 KB flash, 4 KB RAM less a stack reserve) is checked
# by the linker (budget.ld) and again here; any program over it fails the
# build (non-zero exit).
#
# Environment: CC (default avr-gcc), SIZE (default avr-size),
# TINY_STACK_RESERVE (default 512), TINY_AVR_DEFS (the kernel's table sizes).
set -euo pipefail

OUT_DIR=${1:?usage: build.sh OUT_DIR}
HERE=$(cd "$(dirname "$0")" && pwd)
TINY=$(cd "$HERE/../.." && pwd)
CC=${CC:-avr-gcc}
SIZE=${SIZE:-avr-size}
MCU=atmega128
FLASH_BUDGET=40960 # the seed's 40 KB of flash
RAM_BUDGET=4096    # the ATmega128's 4 KB of internal SRAM
STACK_RESERVE=${TINY_STACK_RESERVE:-512}
# Table sizes for the AVR: 10 own tuples as in the seed; a node caches and
# serves few remote tuples (the lamp and the blind each cache one value).
# A secured radio's keys stay in EEPROM (main.c), three senders at most (the
# bridge and two more, as the EEPROM layout holds), 16-bit counters.
DEFS=${TINY_AVR_DEFS:--DTINY_MAX_TUPLES=10 -DTINY_MAX_CACHE=1 -DTINY_MAX_SUBS=2 -DTINY_MAX_SUBSCRIBERS=3 -DTINY_MAX_NEIGHBORS=3 -DTINY_MAX_KEYS=3 -DTINY_KEYS_IN_HAL -DTINY_STATS_16}

CFLAGS=(-std=c99 -Wall -Wextra -Wpedantic -Werror -Os -mmcu=$MCU -DF_CPU=16000000UL
  -ffunction-sections -fdata-sections -I"$TINY/include" -I"$HERE")
# shellcheck disable=SC2206
CFLAGS+=($DEFS)
LDFLAGS=(-mmcu=$MCU -Wl,--gc-sections -Wl,--defsym=TINY_FLASH_BUDGET=$FLASH_BUDGET
  -Wl,--defsym=TINY_RAM_BUDGET=$RAM_BUDGET -Wl,--defsym=TINY_STACK_RESERVE=$STACK_RESERVE)

SOURCES=("$TINY/src/tiny_tuple.c" "$TINY/src/tiny_kernel.c" "$TINY/src/tiny_mac.c" "$TINY/src/tiny_app.c"
  "$TINY/src/tiny_serial.c" "$HERE/avr_uart.c" "$HERE/main.c")
LINK_EXTRA=("$HERE/budget.ld")
# The device programs' report strings stay in flash (avr_report.h).
APP_CFLAGS=(-include avr_report.h)
TARGET=$MCU

# shellcheck source=../build_programs.sh
source "$HERE/../build_programs.sh"
build_programs
