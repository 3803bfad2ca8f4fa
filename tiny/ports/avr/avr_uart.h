/* UART0 of the ATmega128 as the link to an XBee-like serial radio:
 * interrupt-driven reception into a ring buffer, polled transmission, and
 * the serial framing of tiny_serial.h (0x7E, LEN, frame, checksum). */
#ifndef TINY_AVR_UART_H
#define TINY_AVR_UART_H

#include <stdint.h>

#include "tiny_kernel.h"
#include "tiny_serial.h"

#ifndef TINY_AVR_BAUD
#define TINY_AVR_BAUD 38400ul
#endif
#ifndef TINY_AVR_RX_RING
#define TINY_AVR_RX_RING 64 /* bytes; a power of two, at most 256 */
#endif

typedef struct avr_uart_stats {
  uint16_t rx_overflow; /* bytes lost because the ring was full */
  uint16_t rx_errors;   /* framing / data overrun errors seen by the USART */
} avr_uart_stats;

/* 8N1 at TINY_AVR_BAUD, RX interrupt on. Call with interrupts disabled. */
void avr_uart_init(void);
/* The radio HAL on UART0 (send/recv; now_ms is filled in by main.c). */
tiny_hal avr_uart_hal(void);
/* Counters of the driver and of the serial decoder. */
avr_uart_stats avr_uart_get_stats(void);
const tiny_serial_rx *avr_uart_decoder(void);

#endif /* TINY_AVR_UART_H */
