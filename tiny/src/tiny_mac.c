/* SipHash-2-4 and secured frames; see tiny_mac.h. The rounds are those of
 * the reference implementation (public domain / CC0, github.com/veorq/
 * SipHash), with each 64-bit word held as two 32-bit halves: the 8- and
 * 16-bit MCUs (and clang's MSP430 target, which has no 64-bit shift
 * helpers here) then need 32-bit operations only. The reference's test
 * vectors, and libsodium's values, are checked in tests/tiny. */
#include "tiny_mac.h"

typedef struct word64 {
  uint32_t hi, lo;
} word64;

static word64 load64(const uint8_t *p) {
  word64 w;
  w.lo = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
  w.hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 | (uint32_t)p[7] << 24;
  return w;
}

static word64 add(word64 a, word64 b) {
  word64 r;
  r.lo = a.lo + b.lo;
  r.hi = a.hi + b.hi + (r.lo < a.lo ? 1u : 0u);
  return r;
}

static word64 xor64(word64 a, word64 b) {
  word64 r;
  r.lo = a.lo ^ b.lo;
  r.hi = a.hi ^ b.hi;
  return r;
}

/* Rotates left by b bits, 0 < b < 32, or b = 32. */
static word64 rotl(word64 a, unsigned b) {
  word64 r;
  if (b == 32) {
    r.lo = a.hi;
    r.hi = a.lo;
    return r;
  }
  r.hi = (a.hi << b) | (a.lo >> (32u - b));
  r.lo = (a.lo << b) | (a.hi >> (32u - b));
  return r;
}

static void sipround(word64 v[4]) {
  v[0] = add(v[0], v[1]);
  v[1] = xor64(rotl(v[1], 13), v[0]);
  v[0] = rotl(v[0], 32);
  v[2] = add(v[2], v[3]);
  v[3] = xor64(rotl(v[3], 16), v[2]);
  v[0] = add(v[0], v[3]);
  v[3] = xor64(rotl(v[3], 21), v[0]);
  v[2] = add(v[2], v[1]);
  v[1] = xor64(rotl(v[1], 17), v[2]);
  v[2] = rotl(v[2], 32);
}

static void compress(word64 v[4], word64 m) {
  v[3] = xor64(v[3], m);
  sipround(v);
  sipround(v);
  v[0] = xor64(v[0], m);
}

static word64 constant(uint32_t hi, uint32_t lo) {
  word64 w;
  w.hi = hi;
  w.lo = lo;
  return w;
}

void tiny_siphash24(const uint8_t key[TINY_MAC_KEY_SIZE], const uint8_t *msg, size_t len,
                    uint8_t out[TINY_MAC_SIZE]) {
  word64 v[4], last;
  const word64 k0 = load64(key), k1 = load64(key + 8);
  uint8_t tail[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  size_t i, blocks = len / 8;
  int r;
  v[0] = xor64(constant(0x736f6d65u, 0x70736575u), k0);
  v[1] = xor64(constant(0x646f7261u, 0x6e646f6du), k1);
  v[2] = xor64(constant(0x6c796765u, 0x6e657261u), k0);
  v[3] = xor64(constant(0x74656462u, 0x79746573u), k1);
  for (i = 0; i < blocks; ++i) compress(v, load64(msg + 8 * i));
  for (i = 0; i < (len & 7u); ++i) tail[i] = msg[8 * blocks + i];
  tail[7] = (uint8_t)len; /* the length's low byte is the last byte of the last word */
  last = load64(tail);
  compress(v, last);
  v[2].lo ^= 0xffu;
  for (r = 0; r < 4; ++r) sipround(v);
  last = xor64(xor64(v[0], v[1]), xor64(v[2], v[3]));
  for (i = 0; i < 4; ++i) {
    out[i] = (uint8_t)(last.lo >> (8 * i));
    out[4 + i] = (uint8_t)(last.hi >> (8 * i));
  }
}

size_t tiny_seal_frame(uint8_t *buf, size_t len, const uint8_t key[TINY_MAC_KEY_SIZE],
                       uint32_t counter) {
  int i;
  if (len < TINY_FRAME_HEADER_SIZE || len + TINY_SECURED_OVERHEAD > TINY_FRAME_MAX) return 0;
  buf[TINY_FOFF_VERSION] = TINY_SECURED_VERSION;
  for (i = 0; i < 4; ++i) buf[len + (size_t)i] = (uint8_t)(counter >> (8 * i));
  tiny_siphash24(key, buf, len + TINY_COUNTER_SIZE, buf + len + TINY_COUNTER_SIZE);
  return len + TINY_SECURED_OVERHEAD;
}

uint32_t tiny_frame_counter(const uint8_t *buf, size_t len) {
  const uint8_t *p;
  if (len < TINY_FRAME_HEADER_SIZE + TINY_SECURED_OVERHEAD) return 0;
  p = buf + len - TINY_SECURED_OVERHEAD;
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

int tiny_frame_mac_ok(const uint8_t *buf, size_t len, const uint8_t key[TINY_MAC_KEY_SIZE]) {
  uint8_t mac[TINY_MAC_SIZE], diff = 0;
  int i;
  if (len < TINY_FRAME_HEADER_SIZE + TINY_SECURED_OVERHEAD || len > TINY_FRAME_MAX) return 0;
  if (buf[TINY_FOFF_VERSION] != TINY_SECURED_VERSION) return 0;
  tiny_siphash24(key, buf, len - TINY_MAC_SIZE, mac);
  for (i = 0; i < TINY_MAC_SIZE; ++i) diff |= (uint8_t)(mac[i] ^ buf[len - TINY_MAC_SIZE + i]);
  return diff == 0;
}
