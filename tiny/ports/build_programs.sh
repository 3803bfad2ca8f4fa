# Shared by the MCU ports' build.sh (sourced, not run): compiles the port's
# sources and the four device programs, links each, prints
#   TARGET PROGRAM flash N ram N
# (bytes: flash = .text + .ARM.exidx + .vectors + .data, ram = .data + .bss)
# and fails when a program does not link or is over the seed's budget.
#
# The caller sets: OUT_DIR TINY TARGET CC SIZE FLASH_BUDGET RAM_BUDGET
# STACK_RESERVE, the arrays CFLAGS LDFLAGS SOURCES, and optionally
# LINK_EXTRA (arguments appended to every link, e.g. a budget script) and
# APP_CFLAGS (extra flags for the device programs only, after CFLAGS) and
# LINK (the program that links, with LDFLAGS; default CC).

build_programs() {
  local objs=() src obj app elf text data bss flash ram status=0
  mkdir -p "$OUT_DIR"
  for src in "${SOURCES[@]}"; do
    obj="$OUT_DIR/$(basename "${src%.c}").o"
    "$CC" "${CFLAGS[@]}" -c "$src" -o "$obj"
    objs+=("$obj")
  done
  for app in lamp blind plant parcel; do
    "$CC" "${CFLAGS[@]}" ${APP_CFLAGS[@]+"${APP_CFLAGS[@]}"} -c "$TINY/apps/$app.c" \
      -o "$OUT_DIR/app-$app.o"
    elf="$OUT_DIR/$app.elf"
    if ! "${LINK:-$CC}" "${LDFLAGS[@]}" -o "$elf" "$OUT_DIR/app-$app.o" "${objs[@]}" \
      ${LINK_EXTRA[@]+"${LINK_EXTRA[@]}"}; then
      echo "error: $TARGET $app does not link within the budget" >&2
      status=1
      continue
    fi
    read -r text data bss < <("$SIZE" -A "$elf" | awk '
      $1==".text" || $1==".ARM.exidx" || $1==".vectors" { t += $2 } $1==".data" { d = $2 } $1==".bss" { b = $2 }
      END { print t + 0, d + 0, b + 0 }')
    flash=$((text + data))
    ram=$((data + bss))
    echo "$TARGET $app flash $flash ram $ram"
    if [ "$flash" -gt "$FLASH_BUDGET" ] || [ $((ram + STACK_RESERVE)) -gt "$RAM_BUDGET" ]; then
      echo "error: $TARGET $app over budget ($FLASH_BUDGET flash, $RAM_BUDGET RAM with a" \
        "$STACK_RESERVE-byte stack reserve)" >&2
      status=1
    fi
  done
  return $status
}
