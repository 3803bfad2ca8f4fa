/* main() of the ATmega128 port (the Robostix of the seed's PMote, 16 MHz):
 * runs one device program (linked beside this file) as a tiny node whose
 * radio is an XBee-like serial radio on UART0 (avr_uart.c).
 *
 *  - clock: Timer0 in CTC mode interrupts every millisecond;
 *  - tiny_port_report: toggles the status LED (PB4 unless TINY_AVR_LED_*
 *    say otherwise) and keeps the last value in avr_last_report, and the
 *    event in avr_last_event_P (a string in flash), for a debugger or
 *    simulator to read. The device programs' calls go to avr_port_report_P
 *    with the string in flash (avr_report.h, force-included by build.sh);
 *  - tiny_port_sensor: the light sensor is ADC0 (0..1023 scaled to
 *    0..1000), the weight sensor ADC1 (in grams, 0..1023).
 *
 * The node id is the program's app_default_id() unless TINY_NODE_ID is set.
 *
 * A secured radio (docs/security.md) is provisioned in EEPROM; without the
 * magic bytes the radio is open:
 *   off size
 *   0   2    magic 'P' 'S'
 *   2   16   this node's key
 *   18  2    the bridge's node id (little-endian): its frames and writes
 *   20  16   the bridge's key
 *   36  4    the frame counter (kept through the HAL by tiny_secure)
 *   40  2+16 up to two more senders (id, key; id 0xFFFF: none), e.g. the
 *            plant whose tuples the blind follows
 */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>

#include "avr_uart.h"
#include "tiny_app.h"

#ifndef TINY_AVR_LED_DDR
#define TINY_AVR_LED_DDR DDRB
#define TINY_AVR_LED_PORT PORTB
#define TINY_AVR_LED_BIT PB4
#endif

static volatile uint32_t clock_ms;
static tiny_kernel kernel;
volatile long avr_last_report;
const char *volatile avr_last_event_P; /* flash address (PROGMEM), or NULL */

ISR(TIMER0_COMP_vect) { ++clock_ms; }

static uint32_t now_ms(void *ctx) {
  uint32_t v;
  uint8_t sreg = SREG;
  (void)ctx;
  cli();
  v = clock_ms;
  SREG = sreg;
  return v;
}

/* Timer0: F_CPU / 64 / 250 = 1 kHz at 16 MHz. */
static void clock_init(void) {
  TCCR0 = (1 << WGM01) | (1 << CS02); /* CTC, clk/64 (Timer0's CS0 = 4) */
  OCR0 = (uint8_t)(F_CPU / 64ul / 1000ul - 1ul);
  TIMSK |= (1 << OCIE0);
}

void avr_port_report_P(const char *event_P, long value) {
  avr_last_event_P = event_P;
  avr_last_report = value;
  TINY_AVR_LED_PORT ^= (uint8_t)(1 << TINY_AVR_LED_BIT);
}

/* The plain entry point of tiny_app.h, for callers not compiled with
 * avr_report.h: the event (in RAM) is not kept. */
void tiny_port_report(const char *event, long value) {
  (void)event;
  avr_port_report_P(0, value);
}

static uint16_t adc_read(uint8_t channel) {
  ADMUX = (uint8_t)((1 << REFS0) | (channel & 0x07)); /* AVCC reference */
  ADCSRA = (1 << ADEN) | (1 << ADSC) | (1 << ADPS2) | (1 << ADPS1) | (1 << ADPS0);
  while (ADCSRA & (1 << ADSC)) {
  }
  return ADC;
}

long tiny_port_sensor(uint8_t channel) {
  switch (channel) {
    case TINY_SENSOR_LIGHT:
      return (long)adc_read(0) * 1000l / 1023l;
    case TINY_SENSOR_WEIGHT:
      return (long)adc_read(1);
    default:
      return 0;
  }
}

#define EE_MAGIC ((uint8_t *)0)
#define EE_KEY ((uint8_t *)2)
#define EE_BRIDGE ((uint16_t *)18)
#define EE_BRIDGE_KEY ((uint8_t *)20)
#define EE_COUNTER ((uint32_t *)36)
#define EE_PEERS ((uint8_t *)40)
#define EE_PEER_COUNT 2

static int load_counter(void *ctx, uint32_t *value) {
  (void)ctx;
  *value = eeprom_read_dword(EE_COUNTER);
  if (*value == 0xFFFFFFFFul) *value = 0; /* erased EEPROM */
  return 0;
}

static int store_counter(void *ctx, uint32_t value) {
  (void)ctx;
  eeprom_update_dword(EE_COUNTER, value);
  return 0;
}

/* Where the key of `node` is in EEPROM; NULL if it holds none. */
static const uint8_t *eeprom_key_of(uint16_t node) {
  uint8_t i;
  if (node == kernel.id) return EE_KEY;
  if (node == eeprom_read_word(EE_BRIDGE)) return EE_BRIDGE_KEY;
  for (i = 0; i < EE_PEER_COUNT; ++i) {
    const uint8_t *at = EE_PEERS + i * (2 + TINY_MAC_KEY_SIZE);
    if (eeprom_read_word((const uint16_t *)at) == node) return at + 2;
  }
  return NULL;
}

/* The keys stay in EEPROM (TINY_KEYS_IN_HAL): read when a frame is sealed
 * or checked, 16 bytes of RAM saved per key. */
static int load_key(void *ctx, uint16_t node, uint8_t key[TINY_MAC_KEY_SIZE]) {
  const uint8_t *at = eeprom_key_of(node);
  (void)ctx;
  if (at == NULL) return -1;
  eeprom_read_block(key, at, TINY_MAC_KEY_SIZE);
  return 0;
}

static void secure_from_eeprom(void) {
  uint8_t i;
  if (eeprom_read_byte(EE_MAGIC) != 'P' || eeprom_read_byte(EE_MAGIC + 1) != 'S') return;
  if (tiny_secure(&kernel, NULL) != TINY_OK) return;
  (void)tiny_trust(&kernel, eeprom_read_word(EE_BRIDGE), NULL, 1);
  for (i = 0; i < EE_PEER_COUNT; ++i) {
    uint16_t node = eeprom_read_word((const uint16_t *)(EE_PEERS + i * (2 + TINY_MAC_KEY_SIZE)));
    if (node == 0xFFFFu || node == 0) continue;
    (void)tiny_trust(&kernel, node, NULL, 0);
  }
}

int main(void) {
  tiny_hal hal;
  uint16_t id = tiny_port_node_id();
  cli();
  TINY_AVR_LED_DDR |= (uint8_t)(1 << TINY_AVR_LED_BIT);
  clock_init();
  avr_uart_init();
  sei();
  hal = avr_uart_hal();
  hal.now_ms = now_ms;
  hal.load_counter = load_counter;
  hal.store_counter = store_counter;
  hal.load_key = load_key;
  tiny_init(&kernel, id, &hal);
  secure_from_eeprom();
  app_setup(&kernel);
  for (;;) {
    uint32_t now = now_ms(0);
    tiny_poll(&kernel, now);
    app_loop(&kernel, now);
  }
}
