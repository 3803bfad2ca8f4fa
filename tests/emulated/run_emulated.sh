#!/usr/bin/env bash
# Runs a tiny-node firmware under an emulator whose UART is a UNIX socket in
# a fresh temporary directory, waits for the socket (with a deadline), runs a
# client command against it, and stops the emulator (by its pid) and removes
# the directory whatever happens. The exit status is the client's.
#
#   run_emulated.sh [options] qemu   FIRMWARE.elf -- CLIENT [ARGS...]
#   run_emulated.sh [options] simavr FIRMWARE.elf -- CLIENT [ARGS...]
#
# In CLIENT and ARGS, @SOCKET@ is replaced by the socket's path (e.g.
# `tiny_serial_probe --socket @SOCKET@`, or later
# `peis-tinybridge --serial unix:@SOCKET@ ...`).
#
#   qemu:   qemu-system-arm -M lm3s6965evb with semihosting (a firmware built
#           with -DTINY_ARM_RUN_MS=N exits by itself), UART0 on the socket.
#   simavr: the test tool simavr_uart_socket (tools/, GPL-3: a separate
#           program), USART0 on the socket, paced to real time.
#
# Options:
#   --tool PATH        the simavr_uart_socket program (simavr only)
#   --mcu NAME         simavr MCU (default atmega128)
#   --freq HZ          simavr clock (default 16000000, the port's F_CPU)
#   --eeprom FILE      the EEPROM's contents (simavr only), e.g. a secured
#                      radio's keys (secured_radio.sh)
#   --limit SECONDS    emulator wall-clock limit (default 60; always under
#                      `timeout`)
#   --client-limit S   client wall-clock limit (default 45)
#   --skip REASON      print REASON and exit 77 (CTest: skipped); CMake uses
#                      it when a toolchain or emulator was missing at
#                      configure time
# Exit 77 too when the emulator, the tool or the firmware is missing.
set -uo pipefail

SKIP=77
tool="" mcu=atmega128 freq=16000000 limit=60 client_limit=45 eeprom=()
while [ $# -gt 0 ]; do
  case "$1" in
    --tool) tool=$2; shift 2 ;;
    --mcu) mcu=$2; shift 2 ;;
    --freq) freq=$2; shift 2 ;;
    --eeprom) eeprom=(--eeprom "$2"); shift 2 ;;
    --limit) limit=$2; shift 2 ;;
    --client-limit) client_limit=$2; shift 2 ;;
    --skip) echo "SKIP: $2"; exit $SKIP ;;
    --) shift; break ;;
    -*) echo "error: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
if [ $# -lt 4 ] || [ "$3" != "--" ]; then
  echo "usage: run_emulated.sh [options] qemu|simavr FIRMWARE.elf -- CLIENT [ARGS...]" >&2
  exit 2
fi
emulator=$1 firmware=$2
shift 3

case "$emulator" in
  qemu)
    if ! command -v qemu-system-arm >/dev/null; then
      echo "SKIP: qemu-system-arm is not installed (Debian package qemu-system-arm)"
      exit $SKIP
    fi
    ;;
  simavr)
    if [ -z "$tool" ] || [ ! -x "$tool" ]; then
      echo "SKIP: the simavr_uart_socket tool is not built (needs libsimavr-dev)"
      exit $SKIP
    fi
    ;;
  *) echo "error: unknown emulator $emulator (qemu or simavr)" >&2; exit 2 ;;
esac
if [ ! -f "$firmware" ]; then
  echo "SKIP: firmware $firmware is not built (cross toolchain missing?)"
  exit $SKIP
fi
if ! command -v timeout >/dev/null; then
  echo "SKIP: timeout(1) is not installed"
  exit $SKIP
fi

dir=$(mktemp -d "${TMPDIR:-/tmp}/peis-emu.XXXXXX") || exit 1
sock=$dir/uart.sock
log=$dir/emulator.log
emu_pid=""

# shellcheck disable=SC2317 # (run by the EXIT trap)
cleanup() {
  local status=$? _
  if [ -n "$emu_pid" ] && kill -0 "$emu_pid" 2>/dev/null; then
    kill -TERM "$emu_pid" 2>/dev/null
    for _ in $(seq 50); do # up to 5 s for a clean exit, then KILL
      kill -0 "$emu_pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -KILL "$emu_pid" 2>/dev/null
  fi
  [ -n "$emu_pid" ] && wait "$emu_pid" 2>/dev/null
  if [ -s "$log" ]; then
    echo "---- $emulator output ----"
    cat "$log"
  fi
  rm -rf "$dir"
  exit "$status"
}
trap cleanup EXIT
trap 'exit 143' TERM
trap 'exit 130' INT

# The emulator runs under timeout(1), so it ends even if this script is
# killed without running its trap; its pid is timeout's, which passes our
# TERM on to the emulator.
case "$emulator" in
  qemu)
    timeout "$limit" qemu-system-arm -M lm3s6965evb -nographic -monitor none \
      -semihosting-config enable=on,target=native -kernel "$firmware" \
      -serial "unix:$sock,server=on,wait=off" </dev/null >"$log" 2>&1 &
    emu_pid=$!
    ;;
  simavr)
    timeout "$limit" "$tool" --socket "$sock" --mcu "$mcu" --freq "$freq" \
      --time-limit "$limit" "${eeprom[@]}" "$firmware" </dev/null >"$log" 2>&1 &
    emu_pid=$!
    ;;
esac

# Wait for the socket: poll every 50 ms, at most 10 s, and stop early if
# the emulator died.
deadline=$((SECONDS + 10))
while [ ! -S "$sock" ]; do
  if ! kill -0 "$emu_pid" 2>/dev/null; then
    echo "FAIL: $emulator exited before creating its UART socket"
    exit 1
  fi
  if [ $SECONDS -ge $deadline ]; then
    echo "FAIL: no UART socket $sock after 10 s"
    exit 1
  fi
  sleep 0.05
done

client=()
for arg in "$@"; do client+=("${arg//@SOCKET@/$sock}"); done
echo "emulator: $emulator (pid $emu_pid), firmware $firmware, UART on $sock"
echo "client: ${client[*]}"
started=$SECONDS
timeout "$client_limit" "${client[@]}"
status=$?
if [ $status -eq 124 ]; then
  echo "FAIL: the client did not finish within $client_limit s"
fi
echo "client exit status $status after $((SECONDS - started)) s"
exit $status
