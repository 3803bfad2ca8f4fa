/* UART0 driver of the ATmega128 port: see avr_uart.h. */
#include "avr_uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <string.h>

#ifndef F_CPU
#error "F_CPU must be set (the Robostix runs at 16 MHz)"
#endif

#define RING_MASK (TINY_AVR_RX_RING - 1)
TINY_STATIC_ASSERT(TINY_AVR_RX_RING >= 2 && TINY_AVR_RX_RING <= 256 &&
                       (TINY_AVR_RX_RING & RING_MASK) == 0,
                   "TINY_AVR_RX_RING is a power of two, 2..256");

static volatile uint8_t ring[TINY_AVR_RX_RING];
static volatile uint8_t ring_head; /* written by the ISR */
static volatile uint8_t ring_tail; /* written by the main loop */
static volatile avr_uart_stats stats;
static tiny_serial_rx decoder;

ISR(USART0_RX_vect) {
  uint8_t status = UCSR0A;
  uint8_t byte = UDR0;
  uint8_t next = (uint8_t)((ring_head + 1u) & RING_MASK);
  if (status & ((1 << FE0) | (1 << DOR0))) ++stats.rx_errors;
  if (next == ring_tail) {
    ++stats.rx_overflow;
    return;
  }
  ring[ring_head] = byte;
  ring_head = next;
}

void avr_uart_init(void) {
  const uint16_t ubrr = (uint16_t)((F_CPU + 8ul * TINY_AVR_BAUD) / (16ul * TINY_AVR_BAUD) - 1ul);
  UBRR0H = (uint8_t)(ubrr >> 8);
  UBRR0L = (uint8_t)ubrr;
  UCSR0A = 0;
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00); /* 8 data bits, no parity, 1 stop */
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
  ring_head = 0;
  ring_tail = 0;
  tiny_serial_rx_init(&decoder);
}

static void put_byte(uint8_t b) {
  while (!(UCSR0A & (1 << UDRE0))) {
  }
  UDR0 = b;
}

static int uart_send(void *ctx, const uint8_t *frame, uint8_t len) {
  uint8_t i;
  (void)ctx;
  if (len == 0 || len > TINY_FRAME_MAX) return -1;
  put_byte(TINY_SERIAL_START);
  put_byte(len);
  for (i = 0; i < len; ++i) put_byte(frame[i]);
  put_byte(tiny_serial_checksum(frame, len));
  return 0;
}

/* Drains the ring into the decoder until a whole frame is decoded. */
static int uart_recv(void *ctx, uint8_t *buf, uint8_t cap) {
  (void)ctx;
  while (ring_tail != ring_head) {
    uint8_t byte = ring[ring_tail];
    uint8_t n;
    ring_tail = (uint8_t)((ring_tail + 1u) & RING_MASK);
    n = tiny_serial_rx_byte(&decoder, byte);
    if (n != 0) {
      memcpy(buf, decoder.buf, n < cap ? n : cap);
      return n; /* n > cap: the kernel drops and counts it */
    }
  }
  return 0;
}

tiny_hal avr_uart_hal(void) {
  tiny_hal hal;
  hal.ctx = 0;
  hal.send = uart_send;
  hal.recv = uart_recv;
  hal.now_ms = 0;
  return hal;
}

const avr_uart_stats *avr_uart_get_stats(void) { return (const avr_uart_stats *)&stats; }
const tiny_serial_rx *avr_uart_decoder(void) { return &decoder; }
