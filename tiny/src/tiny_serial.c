/* Serial framing of radio frames: see tiny_serial.h. */
#include "tiny_serial.h"

#include <string.h>

enum { RX_HUNT = 0, RX_LEN = 1, RX_DATA = 2, RX_CHK = 3 };

uint8_t tiny_serial_checksum(const uint8_t *frame, uint8_t n) {
  uint8_t sum = 0, i;
  for (i = 0; i < n; ++i) sum = (uint8_t)(sum + frame[i]);
  return (uint8_t)(0xFFu - sum);
}

uint8_t tiny_serial_encode(uint8_t *out, const uint8_t *frame, uint8_t len) {
  if (len == 0 || len > TINY_FRAME_MAX) return 0;
  out[0] = TINY_SERIAL_START;
  out[1] = len;
  memcpy(out + 2, frame, len);
  out[2 + len] = tiny_serial_checksum(frame, len);
  return (uint8_t)(len + TINY_SERIAL_OVERHEAD);
}

void tiny_serial_rx_init(tiny_serial_rx *rx) { memset(rx, 0, sizeof *rx); }

uint8_t tiny_serial_rx_byte(tiny_serial_rx *rx, uint8_t byte) {
  switch (rx->state) {
    case RX_LEN:
      if (byte == 0 || byte > TINY_FRAME_MAX) {
        ++rx->bad_length;
        /* This byte may itself start the next frame. */
        rx->state = byte == TINY_SERIAL_START ? RX_LEN : RX_HUNT;
        return 0;
      }
      rx->len = byte;
      rx->got = 0;
      rx->sum = 0;
      rx->state = RX_DATA;
      return 0;
    case RX_DATA:
      rx->buf[rx->got++] = byte;
      rx->sum = (uint8_t)(rx->sum + byte);
      if (rx->got == rx->len) rx->state = RX_CHK;
      return 0;
    case RX_CHK:
      rx->state = RX_HUNT;
      if ((uint8_t)(rx->sum + byte) != 0xFFu) {
        ++rx->bad_checksum;
        if (byte == TINY_SERIAL_START) rx->state = RX_LEN;
        return 0;
      }
      return rx->len;
    default:
      if (byte == TINY_SERIAL_START) rx->state = RX_LEN;
      return 0;
  }
}

int tiny_serial_send(void (*put)(uint8_t byte), const uint8_t *frame, uint8_t len) {
  uint8_t i;
  if (len == 0 || len > TINY_FRAME_MAX) return -1;
  put(TINY_SERIAL_START);
  put(len);
  for (i = 0; i < len; ++i) put(frame[i]);
  put(tiny_serial_checksum(frame, len));
  return 0;
}

void tiny_serial_ring_put(tiny_serial_ring *ring, uint8_t byte) {
  uint8_t next = (uint8_t)((ring->head + 1u) & ring->mask);
  if (next == ring->tail) {
    ++ring->overruns;
    return;
  }
  ring->bytes[ring->head] = byte;
  ring->head = next;
}

uint8_t tiny_serial_ring_recv(tiny_serial_ring *ring, tiny_serial_rx *rx, uint8_t *buf,
                              uint8_t cap) {
  while (ring->tail != ring->head) {
    uint8_t byte = ring->bytes[ring->tail];
    uint8_t n;
    ring->tail = (uint8_t)((ring->tail + 1u) & ring->mask);
    n = tiny_serial_rx_byte(rx, byte);
    if (n != 0) {
      memcpy(buf, rx->buf, n < cap ? n : cap);
      return n;
    }
  }
  return 0;
}

static int serial_send(void *ctx, const uint8_t *frame, uint8_t len) {
  const tiny_serial_port *port = (const tiny_serial_port *)ctx;
  return tiny_serial_send(port->put, frame, len);
}

static int serial_recv(void *ctx, uint8_t *buf, uint8_t cap) {
  tiny_serial_port *port = (tiny_serial_port *)ctx;
  return tiny_serial_ring_recv(port->ring, port->rx, buf, cap);
}

tiny_hal tiny_serial_hal(tiny_serial_port *port, uint32_t (*now_ms)(void *ctx)) {
  tiny_hal hal;
  memset(&hal, 0, sizeof hal); /* no counter storage: an open radio */
  hal.ctx = port;
  hal.send = serial_send;
  hal.recv = serial_recv;
  hal.now_ms = now_ms;
  return hal;
}
