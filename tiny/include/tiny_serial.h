/* Serial framing of radio frames (C99, no heap): how a tiny frame travels
 * over a UART to an XBee-like serial radio, or to a base station on a
 * serial line. Layout (docs/tiny-tuple.md, "Serial framing"):
 *
 *   0x7E  LEN  FRAME[LEN]  CHK
 *
 * LEN is 1..TINY_FRAME_MAX (100); CHK = 0xFF - (sum of the LEN frame bytes
 * mod 256), as in XBee API frames (so the frame bytes plus CHK sum to 0xFF).
 * There is no byte escaping: after line noise, a lost byte or a bad
 * checksum, the decoder discards the candidate and resynchronises on the
 * next 0x7E. At most TINY_SERIAL_MAX (103) bytes per frame on the wire.
 */
#ifndef TINY_SERIAL_H
#define TINY_SERIAL_H

#include "tiny_kernel.h"
#include "tiny_tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

#define TINY_SERIAL_START 0x7Eu
#define TINY_SERIAL_OVERHEAD 3 /* start, length, checksum */
#define TINY_SERIAL_MAX (TINY_FRAME_MAX + TINY_SERIAL_OVERHEAD)

/* The checksum of n frame bytes: 0xFF - (sum mod 256). */
uint8_t tiny_serial_checksum(const uint8_t *frame, uint8_t n);

/* Writes frame (1..TINY_FRAME_MAX bytes) with its framing into out (room
 * for len + 3 bytes). Returns the number of bytes written, 0 if len is bad. */
uint8_t tiny_serial_encode(uint8_t *out, const uint8_t *frame, uint8_t len);

/* The decoder: feed it every received byte. */
typedef struct tiny_serial_rx {
  uint8_t state; /* 0 hunt for 0x7E, 1 length, 2 frame bytes, 3 checksum */
  uint8_t len;
  uint8_t got;
  uint8_t sum;
  uint32_t bad_length;   /* LEN 0 or over TINY_FRAME_MAX */
  uint32_t bad_checksum; /* checksum mismatch */
  uint8_t buf[TINY_FRAME_MAX];
} tiny_serial_rx;

void tiny_serial_rx_init(tiny_serial_rx *rx);
/* Takes one byte. Returns the frame length (1..100) when this byte ended a
 * good frame, now in rx->buf until the next call; 0 otherwise. */
uint8_t tiny_serial_rx_byte(tiny_serial_rx *rx, uint8_t byte);

/* Writes frame with its framing byte by byte through put (a port's UART
 * transmit). Returns 0, or -1 if len is not 1..TINY_FRAME_MAX. */
int tiny_serial_send(void (*put)(uint8_t byte), const uint8_t *frame, uint8_t len);

/* A receive ring filled by a UART interrupt: size is a power of two (2..256),
 * the interrupt writes at head, the main loop reads at tail. */
typedef struct tiny_serial_ring {
  volatile uint8_t *bytes;
  uint8_t mask; /* size - 1 */
  volatile uint8_t head;
  volatile uint8_t tail;
  uint16_t overruns; /* bytes lost because the ring was full */
} tiny_serial_ring;

/* Interrupt side: stores one received byte (counted and dropped when full). */
void tiny_serial_ring_put(tiny_serial_ring *ring, uint8_t byte);

/* Main-loop side: feeds the ring's bytes to rx until a whole frame is
 * decoded; copies at most cap bytes of it to buf and returns its length
 * (which may exceed cap: the kernel then drops and counts it), or 0. */
uint8_t tiny_serial_ring_recv(tiny_serial_ring *ring, tiny_serial_rx *rx, uint8_t *buf,
                              uint8_t cap);

/* A UART used as the radio: the port's blocking byte transmit, and the ring
 * its receive interrupt fills with the decoder that reads it. */
typedef struct tiny_serial_port {
  void (*put)(uint8_t byte);
  tiny_serial_ring *ring;
  tiny_serial_rx *rx;
} tiny_serial_port;

/* The kernel's HAL on a serial port (ctx = port): send frames them with
 * tiny_serial_send, recv takes them with tiny_serial_ring_recv. now_ms is
 * the port's clock (may be NULL). */
tiny_hal tiny_serial_hal(tiny_serial_port *port, uint32_t (*now_ms)(void *ctx));

#ifdef __cplusplus
}
#endif

#endif /* TINY_SERIAL_H */
