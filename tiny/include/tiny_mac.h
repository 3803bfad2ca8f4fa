/* Message authentication for a secured tiny radio (docs/security.md):
 * SipHash-2-4 (Aumasson and Bernstein, 2012; the reference algorithm, with
 * a 64-bit tag), and the sealing and checking of a frame's trailer
 * (tiny_tuple.h, "secured frames"). The tinybridge computes the same MAC
 * with libsodium's crypto_shorthash_siphash24; the tests check the two
 * agree. C99, no heap, no tables. */
#ifndef TINY_MAC_H
#define TINY_MAC_H

#include <stddef.h>
#include <stdint.h>

#include "tiny_tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* SipHash-2-4 of msg[0..len) under a 16-byte key: 8 bytes in out. */
void tiny_siphash24(const uint8_t key[TINY_MAC_KEY_SIZE], const uint8_t *msg, size_t len,
                    uint8_t out[TINY_MAC_SIZE]);

/* Seals the frame buf[0..len) in place: sets its version to
 * TINY_SECURED_VERSION and appends the counter and the MAC under `key`.
 * Returns the new length, or 0 if it would exceed TINY_FRAME_MAX. */
size_t tiny_seal_frame(uint8_t *buf, size_t len, const uint8_t key[TINY_MAC_KEY_SIZE],
                       uint32_t counter);

/* The counter of a secured frame of `len` bytes (its trailer), without
 * checking it; 0 if it has none. */
uint32_t tiny_frame_counter(const uint8_t *buf, size_t len);

/* Whether the secured frame buf[0..len) carries a MAC that checks under
 * `key`. Constant time in the MAC's bytes. */
int tiny_frame_mac_ok(const uint8_t *buf, size_t len, const uint8_t key[TINY_MAC_KEY_SIZE]);

#ifdef __cplusplus
}
#endif

#endif /* TINY_MAC_H */
