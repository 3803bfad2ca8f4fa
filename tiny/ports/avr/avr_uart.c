/* UART0 driver of the ATmega128 port: see avr_uart.h. */
#include "avr_uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#ifndef F_CPU
#error "F_CPU must be set (the Robostix runs at 16 MHz)"
#endif

#define RING_MASK (TINY_AVR_RX_RING - 1)
TINY_STATIC_ASSERT(TINY_AVR_RX_RING >= 2 && TINY_AVR_RX_RING <= 256 &&
                       (TINY_AVR_RX_RING & RING_MASK) == 0,
                   "TINY_AVR_RX_RING is a power of two, 2..256");

static volatile uint8_t ring_bytes[TINY_AVR_RX_RING];
static tiny_serial_ring ring = {ring_bytes, RING_MASK, 0, 0, 0};
static volatile uint16_t rx_errors;
static tiny_serial_rx decoder;

ISR(USART0_RX_vect) {
  uint8_t status = UCSR0A;
  uint8_t byte = UDR0;
  if (status & ((1 << FE0) | (1 << DOR0))) ++rx_errors;
  tiny_serial_ring_put(&ring, byte);
}

void avr_uart_init(void) {
  const uint16_t ubrr = (uint16_t)((F_CPU + 8ul * TINY_AVR_BAUD) / (16ul * TINY_AVR_BAUD) - 1ul);
  UBRR0H = (uint8_t)(ubrr >> 8);
  UBRR0L = (uint8_t)ubrr;
  UCSR0A = 0;
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8 data bits, no parity, 1 stop */
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
  ring.head = 0;
  ring.tail = 0;
  tiny_serial_rx_init(&decoder);
}

static void put_byte(uint8_t b) {
  while (!(UCSR0A & (1 << UDRE0))) {
  }
  UDR0 = b;
}

static tiny_serial_port uart = {put_byte, &ring, &decoder};

tiny_hal avr_uart_hal(void) { return tiny_serial_hal(&uart, 0); }

avr_uart_stats avr_uart_get_stats(void) {
  avr_uart_stats stats;
  stats.rx_overflow = ring.overruns;
  stats.rx_errors = rx_errors;
  return stats;
}
const tiny_serial_rx *avr_uart_decoder(void) { return &decoder; }
