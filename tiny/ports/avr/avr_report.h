/* Force-included into the device programs by the ATmega128 port's build.sh
 * (`-include avr_report.h`, for tiny/apps/NAME.c only): keeps the event
 * strings of tiny_port_report() in flash instead of RAM.
 *
 * avr-gcc copies every string literal into RAM at start-up (.data), which
 * cost the lamp about 50 bytes of its 1.5 KB. Device programs only ever
 * pass a literal as the event, so the call is rewritten to pass a PSTR()
 * (a PROGMEM string): the app API (tiny_app.h) and the apps' source stay
 * the same on every port. The port reads the string with the pgm_*
 * functions if it ever needs it (today it only keeps a pointer to it).
 */
#ifndef TINY_AVR_REPORT_H
#define TINY_AVR_REPORT_H

#include <avr/pgmspace.h>

#include "tiny_app.h" /* declares tiny_port_report before the macro below */

/* tiny_port_report with an event string in flash (main.c). */
void avr_port_report_P(const char *event_P, long value);

#define tiny_port_report(event, value) avr_port_report_P(PSTR(event), (value))

#endif /* TINY_AVR_REPORT_H */
