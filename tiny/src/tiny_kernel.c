/* The Tiny PEIS-kernel: see tiny_kernel.h for the model. C99, no heap; all
 * state lives in the caller's tiny_kernel struct. */
#include "tiny_kernel.h"

#include <string.h>

/* Milliseconds from `since` to `now` on a wrapping 32-bit clock. */
static uint32_t elapsed(uint32_t now, uint32_t since) { return (uint32_t)(now - since); }

/* Whether seqno a is newer than b (RFC 1982 serial-number arithmetic). */
static int seq_newer(uint32_t a, uint32_t b) {
  uint32_t d = (uint32_t)(a - b);
  return d != 0 && d < 0x80000000u;
}

static uint32_t now_of(const tiny_kernel *k) {
  return k->hal.now_ms != NULL ? k->hal.now_ms(k->hal.ctx) : k->now_ms;
}

static int key_valid(const tiny_key *key) {
  return key != NULL && key->len >= 1 && key->len <= TINY_MAX_SUBKEYS;
}

static int tuple_has_key(const tiny_tuple *t, const tiny_key *key) {
  uint8_t i;
  if (t->key_len != key->len) return 0;
  for (i = 0; i < key->len; ++i) {
    if (tiny_tuple_subkey(t, i) != key->sub[i]) return 0;
  }
  return 1;
}

static int pattern_equal(const tiny_pattern *a, const tiny_pattern *b) {
  return a->owner == b->owner && a->flags == b->flags && tiny_key_equal(&a->key, &b->key);
}

int tiny_pattern_match(const tiny_pattern *p, const tiny_tuple *t) {
  uint8_t i;
  if (p->owner != TINY_ANY_OWNER && p->owner != t->owner) return 0;
  if (p->flags & TINY_SUB_PREFIX) {
    if (t->key_len < p->key.len) return 0;
  } else if (t->key_len != p->key.len) {
    return 0;
  }
  for (i = 0; i < p->key.len; ++i) {
    if (tiny_tuple_subkey(t, i) != p->key.sub[i]) return 0;
  }
  return 1;
}

/* The next frame's counter on a secured radio; the counter stored ahead,
 * a block at a time (before a block's first is used, the next block's
 * start), so a restart never reuses one. 0 if it cannot be stored (the
 * frame is then not sent). */
static int take_counter(tiny_kernel *k, uint32_t *counter) {
  if (k->counter % TINY_COUNTER_BLOCK == 0 &&
      (k->counter > 0xFFFFFFFFu - TINY_COUNTER_BLOCK ||
       k->hal.store_counter(k->hal.ctx, k->counter + TINY_COUNTER_BLOCK) != 0))
    return 0;
  *counter = k->counter++;
  return 1;
}

/* The key of `node` (k->id: this node's own; else sender s's): kept in
 * RAM, or read into buf through the HAL (TINY_KEYS_IN_HAL). NULL if the
 * HAL has none. */
static const uint8_t *key_of(tiny_kernel *k, uint16_t node, const tiny_sender_key *s,
                             uint8_t *buf) {
#ifdef TINY_KEYS_IN_HAL
  (void)s;
  return k->hal.load_key(k->hal.ctx, node, buf) == 0 ? buf : NULL;
#else
  (void)node;
  (void)buf;
  return s != NULL ? s->key : k->key;
#endif
}

static int send_frame(tiny_kernel *k, uint8_t *buf, size_t len) {
  uint32_t counter;
  uint8_t key_buf[TINY_MAC_KEY_SIZE];
  if (k->secured && len != 0) {
    const uint8_t *key = key_of(k, k->id, NULL, key_buf);
    len = key != NULL && take_counter(k, &counter) ? tiny_seal_frame(buf, len, key, counter) : 0;
  }
  if (len == 0 || len > TINY_FRAME_MAX || k->hal.send == NULL ||
      k->hal.send(k->hal.ctx, buf, (uint8_t)len) != 0) {
    ++k->stats.send_errors;
    return TINY_ERR_SEND;
  }
  ++k->stats.frames_tx;
  return TINY_OK;
}

static tiny_sender_key *sender_of(tiny_kernel *k, uint16_t node) {
  uint8_t i;
  for (i = 0; i < TINY_MAX_KEYS; ++i) {
    if (k->senders[i].used && k->senders[i].node == node) return &k->senders[i];
  }
  return NULL;
}

static uint16_t next_seq(tiny_kernel *k) { return k->frame_seq++; }

static int send_tuple(tiny_kernel *k, uint16_t dst, const tiny_tuple *t) {
  uint8_t buf[TINY_FRAME_MAX];
  size_t n = tiny_encode_tuple_frame(buf, k->id, dst, next_seq(k), t);
  return send_frame(k, buf, n);
}

static int send_sub(tiny_kernel *k, uint8_t type, const tiny_pattern *p) {
  uint8_t buf[TINY_FRAME_MAX];
  uint16_t dst = p->owner == TINY_ANY_OWNER ? TINY_ID_BROADCAST : p->owner;
  size_t n = tiny_encode_sub_frame(buf, type, k->id, dst, next_seq(k), p->owner, p->flags, &p->key);
  return send_frame(k, buf, n);
}

static void send_beacon(tiny_kernel *k) {
  uint8_t buf[TINY_FRAME_MAX];
  size_t n = tiny_encode_beacon_frame(buf, k->id, next_seq(k), TINY_BEACON_TINY,
                                      (uint8_t)tiny_own_count(k), elapsed(k->now_ms, k->start_ms));
  (void)send_frame(k, buf, n);
  k->last_beacon_ms = k->now_ms;
}

static void notify(tiny_kernel *k, const tiny_tuple *t) {
  uint8_t i;
  for (i = 0; i < TINY_MAX_SUBS; ++i) {
    tiny_sub_entry *s = &k->subs[i];
    if (s->used && s->cb != NULL && tiny_pattern_match(&s->p, t)) s->cb(k, t, s->user);
  }
}

static int expired(uint32_t now, uint32_t since, uint32_t lifetime) {
  return lifetime != 0 && elapsed(now, since) >= lifetime;
}

/* Sends an own tuple to the subscribers that want it: one frame, addressed
 * to the only subscriber or broadcast to several. */
static void publish(tiny_kernel *k, const tiny_tuple *t) {
  uint8_t i;
  uint16_t dst = TINY_ID_NONE;
  for (i = 0; i < TINY_MAX_SUBSCRIBERS; ++i) {
    const tiny_subscriber_entry *s = &k->subscribers[i];
    if (!s->used || !tiny_pattern_match(&s->p, t)) continue;
    if (dst == TINY_ID_NONE) {
      dst = s->node;
    } else if (dst != s->node) {
      dst = TINY_ID_BROADCAST;
      break;
    }
  }
  if (dst != TINY_ID_NONE) (void)send_tuple(k, dst, t);
}

void tiny_init(tiny_kernel *k, uint16_t id, const tiny_hal *hal) {
  memset(k, 0, sizeof *k);
  k->id = id;
  if (hal != NULL) k->hal = *hal;
}

unsigned tiny_own_count(const tiny_kernel *k) {
  unsigned i, n = 0;
  for (i = 0; i < TINY_MAX_TUPLES; ++i) n += k->own[i].used ? 1u : 0u;
  return n;
}

unsigned tiny_subscriber_count(const tiny_kernel *k) {
  unsigned i, n = 0;
  for (i = 0; i < TINY_MAX_SUBSCRIBERS; ++i) n += k->subscribers[i].used ? 1u : 0u;
  return n;
}

unsigned tiny_neighbor_count(const tiny_kernel *k) {
  unsigned i, n = 0;
  for (i = 0; i < TINY_MAX_NEIGHBORS; ++i) n += k->neighbors[i].used ? 1u : 0u;
  return n;
}

const tiny_stats *tiny_get_stats(const tiny_kernel *k) { return &k->stats; }

int tiny_secure(tiny_kernel *k, const uint8_t key[TINY_MAC_KEY_SIZE]) {
  uint32_t stored = 0;
#ifdef TINY_KEYS_IN_HAL
  (void)key;
  if (k->hal.load_key == NULL) return TINY_ERR_ARG;
#else
  if (key == NULL) return TINY_ERR_ARG;
#endif
  /* The first block at or above the stored counter: stored ahead, so the
   * HAL is known to keep it. */
  if (k->hal.load_counter == NULL || k->hal.store_counter == NULL ||
      k->hal.load_counter(k->hal.ctx, &stored) != 0 ||
      stored > 0xFFFFFFFFu - 2 * TINY_COUNTER_BLOCK)
    return TINY_ERR_ARG;
  stored = (stored + TINY_COUNTER_BLOCK - 1) / TINY_COUNTER_BLOCK * TINY_COUNTER_BLOCK;
  if (k->hal.store_counter(k->hal.ctx, stored + TINY_COUNTER_BLOCK) != 0) return TINY_ERR_ARG;
#ifndef TINY_KEYS_IN_HAL
  memcpy(k->key, key, TINY_MAC_KEY_SIZE);
#endif
  k->counter = stored;
  k->secured = 1;
  return TINY_OK;
}

int tiny_trust(tiny_kernel *k, uint16_t node, const uint8_t key[TINY_MAC_KEY_SIZE],
               uint8_t may_write) {
  uint8_t i;
  tiny_sender_key *slot = sender_of(k, node);
#ifdef TINY_KEYS_IN_HAL
  (void)key;
#else
  if (key == NULL) return TINY_ERR_ARG;
#endif
  if (node == TINY_ID_NONE || node == TINY_ID_BROADCAST) return TINY_ERR_ARG;
  for (i = 0; slot == NULL && i < TINY_MAX_KEYS; ++i) {
    if (!k->senders[i].used) slot = &k->senders[i];
  }
  if (slot == NULL) return TINY_ERR_FULL;
  slot->used = 1;
  slot->node = node;
  slot->may_write = may_write;
  slot->next_counter = 0;
#ifndef TINY_KEYS_IN_HAL
  memcpy(slot->key, key, TINY_MAC_KEY_SIZE);
#endif
  return TINY_OK;
}

static int set_own(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len,
                   uint32_t ts_user, uint32_t expire_ms, uint16_t creator);

int tiny_set(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len) {
  return tiny_set_ex(k, key, data, len, 0, 0);
}

int tiny_set_ex(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len,
                uint32_t ts_user, uint32_t expire_ms) {
  return set_own(k, key, data, len, ts_user, expire_ms, k->id);
}

static int set_own(tiny_kernel *k, const tiny_key *key, const void *data, uint8_t len,
                   uint32_t ts_user, uint32_t expire_ms, uint16_t creator) {
  uint8_t i;
  tiny_own_entry *slot = NULL;
  uint32_t seqno = 1;
  if (!key_valid(key) || len > TINY_MAX_DATA ||
      TINY_SUBKEY_SIZE * key->len + len >
          (k->secured ? TINY_SECURED_STORAGE : TINY_TUPLE_STORAGE_SIZE) ||
      (len > 0 && data == NULL))
    return TINY_ERR_ARG;
  for (i = 0; i < TINY_MAX_TUPLES; ++i) {
    if (k->own[i].used && tuple_has_key(&k->own[i].t, key)) {
      slot = &k->own[i];
      seqno = slot->t.seqno + 1;
      break;
    }
  }
  for (i = 0; slot == NULL && i < TINY_MAX_TUPLES; ++i) {
    if (!k->own[i].used) slot = &k->own[i];
  }
  if (slot == NULL) return TINY_ERR_FULL;
  if (seqno == 0) seqno = 1; /* 0 never names a write */
  if (tiny_tuple_set_key_data(&slot->t, key, data, len) != 0) return TINY_ERR_ARG;
  slot->used = 1;
  slot->t.owner = k->id;
  slot->t.creator = creator;
  slot->t.seqno = seqno;
  slot->t.ts_write = now_of(k);
  slot->t.ts_user = ts_user;
  slot->t.ts_expire = expire_ms;
  publish(k, &slot->t);
  notify(k, &slot->t);
  return TINY_OK;
}

const tiny_tuple *tiny_get(tiny_kernel *k, uint16_t owner, const tiny_key *key) {
  uint8_t i;
  uint32_t now = now_of(k);
  if (!key_valid(key)) return NULL;
  if (owner == k->id) {
    for (i = 0; i < TINY_MAX_TUPLES; ++i) {
      const tiny_tuple *t = &k->own[i].t;
      if (k->own[i].used && tuple_has_key(t, key))
        return expired(now, t->ts_write, t->ts_expire) ? NULL : t;
    }
    return NULL;
  }
  for (i = 0; i < TINY_MAX_CACHE; ++i) {
    const tiny_cache_entry *e = &k->cache[i];
    if (e->used && e->t.owner == owner && tuple_has_key(&e->t, key))
      /* Clocks differ between nodes: a remote lifetime runs from reception. */
      return expired(now, e->received_ms, e->t.ts_expire) ? NULL : &e->t;
  }
  return NULL;
}

int tiny_subscribe(tiny_kernel *k, uint16_t owner, const tiny_key *key, uint8_t flags,
                   tiny_callback cb, void *user) {
  uint8_t i;
  if (key == NULL || key->len > TINY_MAX_SUBKEYS || (flags & ~TINY_SUB_FLAGS_KNOWN) != 0 ||
      (key->len == 0 && !(flags & TINY_SUB_PREFIX)) || owner == TINY_ID_NONE)
    return TINY_ERR_ARG;
  for (i = 0; i < TINY_MAX_SUBS; ++i) {
    tiny_sub_entry *s = &k->subs[i];
    if (s->used) continue;
    memset(s, 0, sizeof *s);
    s->used = 1;
    s->p.owner = owner;
    s->p.flags = flags;
    s->p.key.len = key->len;
    memcpy(s->p.key.sub, key->sub, sizeof(uint16_t) * key->len);
    s->cb = cb;
    s->user = user;
    s->last_sent_ms = now_of(k);
    if (owner != k->id) (void)send_sub(k, TINY_FRAME_SUBSCRIBE, &s->p);
    return (int)i;
  }
  return TINY_ERR_FULL;
}

/* Whether any subscription still wants a cached tuple. */
static int wanted(const tiny_kernel *k, const tiny_tuple *t) {
  uint8_t i;
  for (i = 0; i < TINY_MAX_SUBS; ++i) {
    if (k->subs[i].used && tiny_pattern_match(&k->subs[i].p, t)) return 1;
  }
  return 0;
}

int tiny_unsubscribe(tiny_kernel *k, int handle) {
  uint8_t i;
  tiny_sub_entry *s;
  if (handle < 0 || handle >= TINY_MAX_SUBS || !k->subs[handle].used) return TINY_ERR_ARG;
  s = &k->subs[handle];
  if (s->p.owner != k->id) (void)send_sub(k, TINY_FRAME_UNSUBSCRIBE, &s->p);
  s->used = 0;
  for (i = 0; i < TINY_MAX_CACHE; ++i) {
    if (k->cache[i].used && !wanted(k, &k->cache[i].t)) k->cache[i].used = 0;
  }
  return TINY_OK;
}

static void on_tuple(tiny_kernel *k, const tiny_frame *f) {
  uint8_t i;
  tiny_cache_entry *slot = NULL;
  const tiny_tuple *t = &f->tuple;
  tiny_key key;
  if (t->owner == k->id) { /* our own tuple, echoed back by someone */
    ++k->stats.not_for_me;
    return;
  }
  if (!wanted(k, t)) {
    ++k->stats.tuples_unwanted;
    return;
  }
  tiny_tuple_key(t, &key);
  for (i = 0; i < TINY_MAX_CACHE; ++i) {
    tiny_cache_entry *e = &k->cache[i];
    if (e->used && e->t.owner == t->owner && tuple_has_key(&e->t, &key)) {
      if (!e->seq_reset && !seq_newer(t->seqno, e->t.seqno)) {
        ++k->stats.tuples_stale;
        return;
      }
      slot = e;
      break;
    }
  }
  for (i = 0; slot == NULL && i < TINY_MAX_CACHE; ++i) {
    if (!k->cache[i].used) slot = &k->cache[i];
  }
  if (slot == NULL) {
    ++k->stats.cache_full;
    return;
  }
  slot->used = 1;
  slot->seq_reset = 0;
  slot->received_ms = k->now_ms;
  slot->t = *t;
  ++k->stats.tuples_accepted;
  notify(k, &slot->t);
}

/* A write request to one of our tuples: the owner applies it as its own
 * write (new seqno, creator = the writer) and publishes the result. */
static void on_write(tiny_kernel *k, const tiny_frame *f) {
  const tiny_tuple *t = &f->tuple;
  tiny_key key;
  if (t->owner != k->id) {
    ++k->stats.writes_refused;
    return;
  }
  tiny_tuple_key(t, &key);
  if (set_own(k, &key, tiny_tuple_data(t), t->data_len, t->ts_user, t->ts_expire, t->creator) ==
      TINY_OK) {
    ++k->stats.writes_accepted;
  } else {
    ++k->stats.writes_refused;
  }
}

static void on_subscribe(tiny_kernel *k, const tiny_frame *f) {
  uint8_t i;
  tiny_pattern p;
  tiny_subscriber_entry *slot = NULL;
  if (f->sub_owner != k->id && f->sub_owner != TINY_ANY_OWNER) {
    ++k->stats.not_for_me;
    return;
  }
  p.owner = f->sub_owner;
  p.flags = f->sub_flags;
  p.key = f->sub_key;
  for (i = 0; i < TINY_MAX_SUBSCRIBERS; ++i) {
    tiny_subscriber_entry *s = &k->subscribers[i];
    if (s->used && s->node == f->src && pattern_equal(&s->p, &p)) {
      slot = s;
      break;
    }
  }
  if (f->type == TINY_FRAME_UNSUBSCRIBE) {
    if (slot != NULL) slot->used = 0;
    return;
  }
  for (i = 0; slot == NULL && i < TINY_MAX_SUBSCRIBERS; ++i) {
    if (!k->subscribers[i].used) slot = &k->subscribers[i];
  }
  if (slot == NULL) {
    ++k->stats.subscribers_full;
    return;
  }
  slot->used = 1;
  slot->node = f->src;
  slot->p = p;
  slot->last_renew_ms = k->now_ms;
  /* Answer every (re)subscription with the current values: a value lost on
   * the radio is recovered at the next renewal (duplicates are stale). */
  for (i = 0; i < TINY_MAX_TUPLES; ++i) {
    const tiny_tuple *t = &k->own[i].t;
    if (k->own[i].used && tiny_pattern_match(&p, t) &&
        !expired(k->now_ms, t->ts_write, t->ts_expire))
      (void)send_tuple(k, f->src, t);
  }
}

static void on_beacon(tiny_kernel *k, const tiny_frame *f) {
  uint8_t i;
  tiny_neighbor_entry *slot = NULL;
  for (i = 0; i < TINY_MAX_NEIGHBORS; ++i) {
    if (k->neighbors[i].used && k->neighbors[i].node == f->src) {
      slot = &k->neighbors[i];
      break;
    }
  }
  if (slot != NULL && f->beacon_uptime_ms + TINY_BEACON_INTERVAL_MS < slot->uptime_ms) {
    /* The node restarted: its seqnos start again. (The margin keeps a late
     * or reordered beacon from looking like a restart.) */
    for (i = 0; i < TINY_MAX_CACHE; ++i) {
      if (k->cache[i].used && k->cache[i].t.owner == f->src) k->cache[i].seq_reset = 1;
    }
  }
  for (i = 0; slot == NULL && i < TINY_MAX_NEIGHBORS; ++i) {
    if (!k->neighbors[i].used) slot = &k->neighbors[i];
  }
  if (slot == NULL) {
    ++k->stats.neighbors_full;
    return;
  }
  slot->used = 1;
  slot->node = f->src;
  slot->flags = f->beacon_flags;
  slot->uptime_ms = f->beacon_uptime_ms;
  slot->last_seen_ms = k->now_ms;
}

/* A secured radio: the frame's sender, if it is known, its MAC checks and
 * its counter is new (then the trailer is cut off: *n shrinks). */
static tiny_sender_key *authentic(tiny_kernel *k, const uint8_t *buf, int *n) {
  tiny_sender_key *s;
  const uint8_t *key;
  uint8_t key_buf[TINY_MAC_KEY_SIZE];
  uint32_t counter;
  uint16_t src;
  if (*n < TINY_FRAME_HEADER_SIZE + TINY_SECURED_OVERHEAD ||
      buf[TINY_FOFF_VERSION] != TINY_SECURED_VERSION) {
    ++k->stats.drop_unsecured;
    return NULL;
  }
  src = (uint16_t)(buf[TINY_FOFF_SRC] | buf[TINY_FOFF_SRC + 1] << 8);
  s = sender_of(k, src);
  if (s == NULL) {
    if (src == k->id) {
      ++k->stats.not_for_me;
    } else {
      ++k->stats.drop_unknown_sender;
    }
    return NULL;
  }
  key = key_of(k, src, s, key_buf);
  if (key == NULL || !tiny_frame_mac_ok(buf, (size_t)*n, key)) {
    ++k->stats.drop_bad_mac;
    return NULL;
  }
  counter = tiny_frame_counter(buf, (size_t)*n);
  if (counter < s->next_counter) {
    ++k->stats.drop_replay;
    return NULL;
  }
  s->next_counter = counter + 1u;
  *n -= TINY_SECURED_OVERHEAD;
  return s;
}

static void handle_frame(tiny_kernel *k, const uint8_t *buf, int n) {
  tiny_frame f;
  tiny_sender_key *sender = NULL;
  if (n > TINY_FRAME_MAX) { /* cut by the HAL: count it, never read it */
    ++k->stats.frames_rx;
    ++k->stats.drop_bad_length;
    return;
  }
  if (k->secured && (sender = authentic(k, buf, &n)) == NULL) {
    ++k->stats.frames_rx;
    return;
  }
  if (tiny_decode_frame(buf, (size_t)n, &f, &k->stats) != TINY_DECODE_OK) return;
  if (f.src == k->id || (f.dst != k->id && f.dst != TINY_ID_BROADCAST)) {
    ++k->stats.not_for_me;
    return;
  }
  switch (f.type) {
    case TINY_FRAME_TUPLE:
      /* On a secured radio a node speaks for its own tuples only; the
       * bridge (a writer) relays those of full PEIS. */
      if (sender != NULL && !sender->may_write && f.tuple.owner != f.src) {
        ++k->stats.drop_forged_owner;
        break;
      }
      on_tuple(k, &f);
      break;
    case TINY_FRAME_SUBSCRIBE:
    case TINY_FRAME_UNSUBSCRIBE:
      on_subscribe(k, &f);
      break;
    case TINY_FRAME_BEACON:
      on_beacon(k, &f);
      break;
    case TINY_FRAME_WRITE:
      if (sender != NULL && !sender->may_write) { /* only the bridge writes */
        ++k->stats.writes_refused;
        break;
      }
      on_write(k, &f);
      break;
    default:
      break; /* tiny_decode_frame accepts no other type */
  }
}

void tiny_poll(tiny_kernel *k, uint32_t now_ms) {
  uint8_t i;
  k->now_ms = now_ms;
  if (!k->started) {
    k->started = 1;
    k->start_ms = now_ms;
    send_beacon(k);
  }
  if (k->hal.recv != NULL) {
    for (i = 0; i < TINY_MAX_RX_PER_POLL; ++i) {
      uint8_t buf[TINY_FRAME_MAX];
      int n = k->hal.recv(k->hal.ctx, buf, (uint8_t)sizeof buf);
      if (n <= 0) break;
      handle_frame(k, buf, n);
    }
  }
  if (elapsed(now_ms, k->last_beacon_ms) >= TINY_BEACON_INTERVAL_MS) send_beacon(k);
  for (i = 0; i < TINY_MAX_SUBS; ++i) {
    tiny_sub_entry *s = &k->subs[i];
    if (s->used && s->p.owner != k->id &&
        elapsed(now_ms, s->last_sent_ms) >= TINY_RESUB_INTERVAL_MS) {
      s->last_sent_ms = now_ms;
      (void)send_sub(k, TINY_FRAME_SUBSCRIBE, &s->p);
    }
  }
  for (i = 0; i < TINY_MAX_SUBSCRIBERS; ++i) {
    tiny_subscriber_entry *s = &k->subscribers[i];
    if (s->used && elapsed(now_ms, s->last_renew_ms) > TINY_SUBSCRIBER_TIMEOUT_MS) s->used = 0;
  }
  for (i = 0; i < TINY_MAX_NEIGHBORS; ++i) {
    tiny_neighbor_entry *nb = &k->neighbors[i];
    if (nb->used && elapsed(now_ms, nb->last_seen_ms) > TINY_NEIGHBOR_TIMEOUT_MS) nb->used = 0;
  }
}
