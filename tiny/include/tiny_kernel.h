/* The Tiny PEIS-kernel (C99, no heap): the same model as the full kernel on
 * a microcontroller. A node owns a few tuples, caches the remote tuples it
 * subscribes to, and talks to other nodes directly over a broadcast radio.
 *
 *  - tiny_set: set an own tuple (static store of TINY_MAX_TUPLES). The owner
 *    sends the new value to the subscribers it knows (one frame: addressed
 *    to the only subscriber, or broadcast when there are several).
 *  - tiny_get: read an own tuple or a cached remote one; never a radio trip.
 *  - tiny_subscribe: (owner, key) or wildcards (TINY_ANY_OWNER, a key
 *    prefix with TINY_SUB_PREFIX); the callback runs on every change. The
 *    subscription is re-sent every TINY_RESUB_INTERVAL_MS; an owner answers
 *    each (re)subscription with its current matching tuples, so values lost
 *    on the radio are recovered at the next renewal.
 *  - An owner forgets a subscriber that has not renewed for
 *    TINY_SUBSCRIBER_TIMEOUT_MS.
 *  - A beacon announces the node every TINY_BEACON_INTERVAL_MS; nodes keep a
 *    table of neighbours heard recently. A beacon whose uptime went back
 *    means the node restarted: the seqnos cached for its tuples are reset.
 *  - Per (owner, key), a remote value is taken only if its seqno is newer
 *    (serial-number arithmetic) than the cached one; duplicates and
 *    reordered frames are counted as stale and dropped.
 *
 * Everything happens inside tiny_poll(k, now_ms), which the port's main loop
 * calls often; callbacks run from tiny_poll (or tiny_set, for own tuples).
 * All state is in one tiny_kernel struct the caller provides (a static).
 */
#ifndef TINY_KERNEL_H
#define TINY_KERNEL_H

#include "tiny_mac.h"
#include "tiny_timing.h"
#include "tiny_tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- compile-time sizes (override with -D); timings: tiny_timing.h ---- */
#ifndef TINY_MAX_TUPLES
#define TINY_MAX_TUPLES 10 /* own tuples */
#endif
#ifndef TINY_MAX_CACHE
#define TINY_MAX_CACHE 6 /* cached remote tuples */
#endif
#ifndef TINY_MAX_SUBS
#define TINY_MAX_SUBS 4 /* own subscriptions */
#endif
#ifndef TINY_MAX_SUBSCRIBERS
#define TINY_MAX_SUBSCRIBERS 6 /* remote subscriptions to own tuples */
#endif
#ifndef TINY_MAX_NEIGHBORS
#define TINY_MAX_NEIGHBORS 8
#endif
#ifndef TINY_MAX_RX_PER_POLL
#define TINY_MAX_RX_PER_POLL 8 /* frames taken from the radio per poll */
#endif
#ifndef TINY_MAX_KEYS
#define TINY_MAX_KEYS 4 /* senders whose secured frames this node takes */
#endif
/* TINY_KEYS_IN_HAL (defined by the build, e.g. the ATmega128 port's): the
 * kernel keeps no secured radio's key in RAM (16 bytes each); hal.load_key
 * reads one from non-volatile memory when a frame is sealed or checked. */
#ifndef TINY_COUNTER_BLOCK
#define TINY_COUNTER_BLOCK 256u /* frames per write of the counter to non-volatile memory */
#endif

TINY_STATIC_ASSERT(TINY_MAX_TUPLES >= 1 && TINY_MAX_TUPLES <= 255, "TINY_MAX_TUPLES 1..255");
TINY_STATIC_ASSERT(TINY_MAX_CACHE >= 1 && TINY_MAX_CACHE <= 255, "TINY_MAX_CACHE 1..255");
TINY_STATIC_ASSERT(TINY_MAX_SUBS >= 1 && TINY_MAX_SUBS <= 127, "TINY_MAX_SUBS 1..127");
TINY_STATIC_ASSERT(TINY_MAX_SUBSCRIBERS >= 1 && TINY_MAX_SUBSCRIBERS <= 255,
                   "TINY_MAX_SUBSCRIBERS 1..255");

/* ---- the HAL: a few function pointers (cf. zenoh-pico's link struct) --- */
typedef struct tiny_hal {
  void *ctx; /* passed back to every function */
  /* Send one frame of len <= TINY_FRAME_MAX bytes to every node in range
   * (the radio is a broadcast medium). Returns 0 on success. */
  int (*send)(void *ctx, const uint8_t *frame, uint8_t len);
  /* Take one received frame, without blocking. Returns its length (which
   * may exceed cap: the frame was cut and is dropped), 0 if none. */
  int (*recv)(void *ctx, uint8_t *buf, uint8_t cap);
  /* Milliseconds since an arbitrary origin, wrapping at 2^32. May be NULL:
   * then the time of the last tiny_poll is used. */
  uint32_t (*now_ms)(void *ctx);
  /* A secured radio's frame counter, kept across restarts in non-volatile
   * memory (EEPROM, a file): load the value stored last (0 the first
   * time), store a new one. Return 0 on success. NULL on an open radio. */
  int (*load_counter)(void *ctx, uint32_t *value);
  int (*store_counter)(void *ctx, uint32_t value);
  /* With TINY_KEYS_IN_HAL: copies the key of `node` (this node's own for
   * its id, else a sender's given to tiny_trust) into key. Return 0 on
   * success. Not used (may be NULL) otherwise. */
  int (*load_key)(void *ctx, uint16_t node, uint8_t key[TINY_MAC_KEY_SIZE]);
} tiny_hal;

/* ---- results ----------------------------------------------------------- */
#define TINY_OK 0
#define TINY_ERR_ARG (-1)  /* bad key, data too long, bad handle */
#define TINY_ERR_FULL (-2) /* the static table is full */
#define TINY_ERR_SEND (-3) /* the HAL could not send */

struct tiny_kernel;
/* Runs when a subscribed tuple changed. The tuple lives in the kernel's
 * tables and is valid until the next tiny_* call. */
typedef void (*tiny_callback)(struct tiny_kernel *k, const tiny_tuple *t, void *user);

typedef struct tiny_pattern {
  uint16_t owner; /* or TINY_ANY_OWNER */
  uint8_t flags;  /* TINY_SUB_PREFIX */
  tiny_key key;
} tiny_pattern;

typedef struct tiny_own_entry {
  uint8_t used;
  tiny_tuple t;
} tiny_own_entry;

typedef struct tiny_cache_entry {
  uint8_t used;
  uint8_t seq_reset; /* owner restarted: take the next value whatever its seqno */
  uint32_t received_ms;
  tiny_tuple t;
} tiny_cache_entry;

typedef struct tiny_sub_entry {
  uint8_t used;
  tiny_pattern p;
  tiny_callback cb;
  void *user;
  uint32_t last_sent_ms;
} tiny_sub_entry;

typedef struct tiny_subscriber_entry {
  uint8_t used;
  uint16_t node;
  tiny_pattern p;
  uint32_t last_renew_ms;
} tiny_subscriber_entry;

typedef struct tiny_neighbor_entry {
  uint8_t used;
  uint8_t flags;
  uint16_t node;
  uint32_t uptime_ms;
  uint32_t last_seen_ms;
} tiny_neighbor_entry;

/* A sender whose secured frames this node takes (tiny_trust). */
typedef struct tiny_sender_key {
  uint8_t used;
  uint8_t may_write; /* its WRITE frames are applied (the bridge's) */
  uint16_t node;
  uint32_t next_counter; /* the lowest counter still taken from it */
#ifndef TINY_KEYS_IN_HAL
  uint8_t key[TINY_MAC_KEY_SIZE];
#endif
} tiny_sender_key;

typedef struct tiny_kernel {
  uint16_t id;
  tiny_hal hal;
  uint32_t now_ms;   /* time of the last poll */
  uint32_t start_ms; /* time of the first poll */
  uint32_t last_beacon_ms;
  uint8_t started;
  uint16_t frame_seq;
  tiny_stats stats;
  tiny_own_entry own[TINY_MAX_TUPLES];
  tiny_cache_entry cache[TINY_MAX_CACHE];
  tiny_sub_entry subs[TINY_MAX_SUBS];
  tiny_subscriber_entry subscribers[TINY_MAX_SUBSCRIBERS];
  tiny_neighbor_entry neighbors[TINY_MAX_NEIGHBORS];
  /* A secured radio (tiny_secure): this node's key and frame counter, and
   * the senders it takes frames from. */
  uint8_t secured;
#ifndef TINY_KEYS_IN_HAL
  uint8_t key[TINY_MAC_KEY_SIZE];
#endif
  /* The next frame's counter; before the first of each block of
   * TINY_COUNTER_BLOCK, the next block's start is stored, so no frame
   * after a restart carries a counter used before. */
  uint32_t counter;
  tiny_sender_key senders[TINY_MAX_KEYS];
} tiny_kernel;

/* Resets *k to a node with id `id` (1..0xFFFE) on the given HAL. */
void tiny_init(tiny_kernel *k, uint16_t id, const tiny_hal *hal);

/* One step: receive and handle pending frames, send due beacons and
 * subscription renewals, forget silent subscribers and neighbours. */
void tiny_poll(tiny_kernel *k, uint32_t now_ms);

/* Sets an own tuple (ts_user 0, never expires). Returns TINY_OK,
 * TINY_ERR_ARG or TINY_ERR_FULL (a new key and no free slot; existing keys
 * can always be updated). A send failure is counted, not returned. */
int tiny_set(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len);
/* The same with a user timestamp and a lifetime in ms (0 = never expires). */
int tiny_set_ex(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len,
                uint32_t ts_user, uint32_t expire_ms);

/* The current value of (owner, key): an own tuple if owner is this node,
 * else the cached remote value. NULL if unknown or expired. */
const tiny_tuple *tiny_get(tiny_kernel *k, uint16_t owner, const tiny_key *key);

/* Subscribes to (owner, key); owner may be TINY_ANY_OWNER, and with
 * TINY_SUB_PREFIX in flags the key is a prefix (len 0 = every key). Sends the
 * subscription at once and then every TINY_RESUB_INTERVAL_MS. cb may be NULL
 * (values are cached all the same). Returns a handle >= 0, or an error. */
int tiny_subscribe(tiny_kernel *k, uint16_t owner, const tiny_key *key, uint8_t flags,
                   tiny_callback cb, void *user);
/* Ends a subscription (and tells the owner). */
int tiny_unsubscribe(tiny_kernel *k, int handle);

/* Whether tuple t matches a pattern. */
int tiny_pattern_match(const tiny_pattern *p, const tiny_tuple *t);

/* A secured radio (docs/security.md): from now on every frame this node
 * sends carries its counter and a MAC under `key`, and it takes only
 * secured frames of the senders added with tiny_trust. A tuple then holds
 * at most TINY_SECURED_STORAGE (58) bytes of key and data. TINY_ERR_ARG if
 * the HAL cannot keep the counter (load_counter, store_counter). With
 * TINY_KEYS_IN_HAL, `key` is not kept (it may be NULL): hal.load_key gives
 * it, and must be set. */
int tiny_secure(tiny_kernel *k, const uint8_t key[TINY_MAC_KEY_SIZE]);
/* Takes secured frames from `node` (its MAC under `key`); with `may_write`
 * also its WRITE frames (the bridge's). Again for a known node: replaces
 * its key. TINY_ERR_FULL when TINY_MAX_KEYS senders are known. With
 * TINY_KEYS_IN_HAL, `key` is not kept (it may be NULL): hal.load_key gives
 * it. */
int tiny_trust(tiny_kernel *k, uint16_t node, const uint8_t key[TINY_MAC_KEY_SIZE],
               uint8_t may_write);

/* Counters, live remote subscribers of own tuples, neighbours heard. */
const tiny_stats *tiny_get_stats(const tiny_kernel *k);
unsigned tiny_subscriber_count(const tiny_kernel *k);
unsigned tiny_neighbor_count(const tiny_kernel *k);
unsigned tiny_own_count(const tiny_kernel *k);

#ifdef __cplusplus
}
#endif

#endif /* TINY_KERNEL_H */
