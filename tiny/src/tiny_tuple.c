/* Encoding and decoding of tiny tuples and radio frames: byte by byte,
 * little-endian, independent of struct layout. See tiny_tuple.h. */
#include "tiny_tuple.h"

#include <string.h>

static void put16(uint8_t *p, uint16_t v) {
  p[0] = (uint8_t)(v & 0xFFu);
  p[1] = (uint8_t)(v >> 8);
}

static void put32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)(v & 0xFFu);
  p[1] = (uint8_t)((v >> 8) & 0xFFu);
  p[2] = (uint8_t)((v >> 16) & 0xFFu);
  p[3] = (uint8_t)(v >> 24);
}

static uint16_t get16(const uint8_t *p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }

static uint32_t get32(const uint8_t *p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

tiny_key tiny_key1(uint16_t sub0) {
  tiny_key k;
  memset(&k, 0, sizeof k);
  k.len = 1;
  k.sub[0] = sub0;
  return k;
}

int tiny_key_equal(const tiny_key *a, const tiny_key *b) {
  uint8_t i;
  if (a->len != b->len) return 0;
  for (i = 0; i < a->len && i < TINY_MAX_SUBKEYS; ++i) {
    if (a->sub[i] != b->sub[i]) return 0;
  }
  return 1;
}

uint16_t tiny_tuple_subkey(const tiny_tuple *t, uint8_t i) {
  if (i >= t->key_len || i >= TINY_MAX_SUBKEYS) return 0;
  return get16(t->storage + TINY_SUBKEY_SIZE * i);
}

void tiny_tuple_key(const tiny_tuple *t, tiny_key *out) {
  uint8_t i;
  memset(out, 0, sizeof *out);
  out->len = t->key_len <= TINY_MAX_SUBKEYS ? t->key_len : TINY_MAX_SUBKEYS;
  for (i = 0; i < out->len; ++i) out->sub[i] = tiny_tuple_subkey(t, i);
}

const uint8_t *tiny_tuple_data(const tiny_tuple *t) {
  uint8_t k = t->key_len <= TINY_MAX_SUBKEYS ? t->key_len : TINY_MAX_SUBKEYS;
  return t->storage + TINY_SUBKEY_SIZE * k;
}

static int lengths_valid(uint8_t key_len, uint8_t data_len) {
  return key_len >= 1 && key_len <= TINY_MAX_SUBKEYS && data_len <= TINY_MAX_DATA &&
         TINY_SUBKEY_SIZE * key_len + data_len <= TINY_TUPLE_STORAGE_SIZE;
}

int tiny_tuple_set_key_data(tiny_tuple *t, const tiny_key *key, const void *data,
                            uint8_t data_len) {
  uint8_t i;
  if (!lengths_valid(key->len, data_len)) return -1;
  if (data_len > 0 && data == NULL) return -1;
  memset(t->storage, 0, sizeof t->storage);
  t->key_len = key->len;
  t->data_len = data_len;
  for (i = 0; i < key->len; ++i) put16(t->storage + TINY_SUBKEY_SIZE * i, key->sub[i]);
  if (data_len > 0) memcpy(t->storage + TINY_SUBKEY_SIZE * key->len, data, data_len);
  return 0;
}

size_t tiny_tuple_wire_size(const tiny_tuple *t) {
  return (size_t)TINY_TUPLE_HEADER_SIZE + (size_t)TINY_SUBKEY_SIZE * t->key_len + t->data_len;
}

size_t tiny_tuple_encode(const tiny_tuple *t, uint8_t *buf, size_t cap) {
  size_t n;
  if (!lengths_valid(t->key_len, t->data_len)) return 0;
  n = tiny_tuple_wire_size(t);
  if (cap < n) return 0;
  put16(buf + TINY_OFF_OWNER, t->owner);
  put16(buf + TINY_OFF_CREATOR, t->creator);
  put32(buf + TINY_OFF_SEQNO, t->seqno);
  put32(buf + TINY_OFF_TS_WRITE, t->ts_write);
  put32(buf + TINY_OFF_TS_USER, t->ts_user);
  put32(buf + TINY_OFF_TS_EXPIRE, t->ts_expire);
  buf[TINY_OFF_KEY_LEN] = t->key_len;
  buf[TINY_OFF_DATA_LEN] = t->data_len;
  memcpy(buf + TINY_OFF_STORAGE, t->storage, n - TINY_TUPLE_HEADER_SIZE);
  return n;
}

tiny_decode_result tiny_tuple_decode(const uint8_t *buf, size_t len, tiny_tuple *out) {
  uint8_t key_len, data_len;
  size_t need;
  if (len < TINY_TUPLE_HEADER_SIZE) return TINY_DECODE_TRUNCATED;
  key_len = buf[TINY_OFF_KEY_LEN];
  data_len = buf[TINY_OFF_DATA_LEN];
  if (key_len > TINY_MAX_SUBKEYS) return TINY_DECODE_TOO_MANY_SUBKEYS;
  if (key_len == 0) return TINY_DECODE_BAD_KEY;
  if (data_len > TINY_MAX_DATA || TINY_SUBKEY_SIZE * key_len + data_len > TINY_TUPLE_STORAGE_SIZE)
    return TINY_DECODE_DATA_TOO_LONG;
  need = (size_t)TINY_TUPLE_HEADER_SIZE + (size_t)TINY_SUBKEY_SIZE * key_len + data_len;
  if (len < need) return TINY_DECODE_TRUNCATED;
  if (len > need) return TINY_DECODE_BAD_LENGTH;
  memset(out, 0, sizeof *out);
  out->owner = get16(buf + TINY_OFF_OWNER);
  out->creator = get16(buf + TINY_OFF_CREATOR);
  out->seqno = get32(buf + TINY_OFF_SEQNO);
  out->ts_write = get32(buf + TINY_OFF_TS_WRITE);
  out->ts_user = get32(buf + TINY_OFF_TS_USER);
  out->ts_expire = get32(buf + TINY_OFF_TS_EXPIRE);
  out->key_len = key_len;
  out->data_len = data_len;
  memcpy(out->storage, buf + TINY_OFF_STORAGE, need - TINY_TUPLE_HEADER_SIZE);
  return TINY_DECODE_OK;
}

static void put_header(uint8_t *buf, uint8_t type, uint16_t src, uint16_t dst, uint16_t seq) {
  buf[TINY_FOFF_TYPE] = type;
  buf[TINY_FOFF_VERSION] = TINY_PROTOCOL_VERSION;
  put16(buf + TINY_FOFF_SRC, src);
  put16(buf + TINY_FOFF_DST, dst);
  put16(buf + TINY_FOFF_SEQ, seq);
}

size_t tiny_encode_tuple_frame(uint8_t *buf, uint16_t src, uint16_t dst, uint16_t seq,
                               const tiny_tuple *t) {
  size_t n = tiny_tuple_encode(t, buf + TINY_FOFF_PAYLOAD, TINY_FRAME_PAYLOAD_MAX);
  if (n == 0) return 0;
  put_header(buf, TINY_FRAME_TUPLE, src, dst, seq);
  return TINY_FRAME_HEADER_SIZE + n;
}

size_t tiny_encode_write_frame(uint8_t *buf, uint16_t src, uint16_t seq, const tiny_tuple *t) {
  size_t n = tiny_encode_tuple_frame(buf, src, t->owner, seq, t);
  if (n != 0) buf[TINY_FOFF_TYPE] = TINY_FRAME_WRITE;
  return n;
}

size_t tiny_encode_sub_frame(uint8_t *buf, uint8_t type, uint16_t src, uint16_t dst, uint16_t seq,
                             uint16_t owner, uint8_t flags, const tiny_key *key) {
  uint8_t i;
  uint8_t *p = buf + TINY_FOFF_PAYLOAD;
  if (type != TINY_FRAME_SUBSCRIBE && type != TINY_FRAME_UNSUBSCRIBE) return 0;
  if (key->len > TINY_MAX_SUBKEYS || (flags & ~TINY_SUB_FLAGS_KNOWN) != 0) return 0;
  if (key->len == 0 && !(flags & TINY_SUB_PREFIX)) return 0;
  put_header(buf, type, src, dst, seq);
  put16(p, owner);
  p[2] = flags;
  p[3] = key->len;
  for (i = 0; i < key->len; ++i) put16(p + TINY_SUB_FIXED_SIZE + TINY_SUBKEY_SIZE * i, key->sub[i]);
  return (size_t)TINY_FRAME_HEADER_SIZE + TINY_SUB_FIXED_SIZE + (size_t)TINY_SUBKEY_SIZE * key->len;
}

size_t tiny_encode_beacon_frame(uint8_t *buf, uint16_t src, uint16_t seq, uint8_t flags,
                                uint8_t tuples, uint32_t uptime_ms) {
  uint8_t *p = buf + TINY_FOFF_PAYLOAD;
  put_header(buf, TINY_FRAME_BEACON, src, TINY_ID_BROADCAST, seq);
  p[0] = flags;
  p[1] = tuples;
  put32(p + 2, uptime_ms);
  return TINY_FRAME_HEADER_SIZE + TINY_BEACON_SIZE;
}

static tiny_decode_result decode(const uint8_t *buf, size_t len, tiny_frame *out) {
  const uint8_t *p;
  size_t plen;
  uint8_t i, key_len;
  if (buf == NULL || len < TINY_FRAME_HEADER_SIZE) return TINY_DECODE_TRUNCATED;
  if (len > TINY_FRAME_MAX) return TINY_DECODE_BAD_LENGTH;
  /* A secured frame's trailer is checked and cut off before (tiny_mac.h). */
  if (buf[TINY_FOFF_VERSION] != TINY_PROTOCOL_VERSION &&
      buf[TINY_FOFF_VERSION] != TINY_SECURED_VERSION)
    return TINY_DECODE_BAD_VERSION;
  memset(out, 0, sizeof *out);
  out->type = buf[TINY_FOFF_TYPE];
  out->src = get16(buf + TINY_FOFF_SRC);
  out->dst = get16(buf + TINY_FOFF_DST);
  out->seq = get16(buf + TINY_FOFF_SEQ);
  p = buf + TINY_FOFF_PAYLOAD;
  plen = len - TINY_FRAME_HEADER_SIZE;
  switch (out->type) {
    case TINY_FRAME_TUPLE:
    case TINY_FRAME_WRITE:
      if (out->src == TINY_ID_NONE || out->src == TINY_ID_BROADCAST) return TINY_DECODE_BAD_SRC;
      return tiny_tuple_decode(p, plen, &out->tuple);
    case TINY_FRAME_SUBSCRIBE:
    case TINY_FRAME_UNSUBSCRIBE:
      if (plen < TINY_SUB_FIXED_SIZE) return TINY_DECODE_TRUNCATED;
      key_len = p[3];
      if (key_len > TINY_MAX_SUBKEYS) return TINY_DECODE_TOO_MANY_SUBKEYS;
      if (plen < (size_t)TINY_SUB_FIXED_SIZE + (size_t)TINY_SUBKEY_SIZE * key_len)
        return TINY_DECODE_TRUNCATED;
      if (plen > (size_t)TINY_SUB_FIXED_SIZE + (size_t)TINY_SUBKEY_SIZE * key_len)
        return TINY_DECODE_BAD_LENGTH;
      out->sub_owner = get16(p);
      out->sub_flags = p[2];
      if ((out->sub_flags & ~TINY_SUB_FLAGS_KNOWN) != 0) return TINY_DECODE_BAD_KEY;
      if (key_len == 0 && !(out->sub_flags & TINY_SUB_PREFIX)) return TINY_DECODE_BAD_KEY;
      if (out->src == TINY_ID_NONE || out->src == TINY_ID_BROADCAST) return TINY_DECODE_BAD_SRC;
      out->sub_key.len = key_len;
      for (i = 0; i < key_len; ++i)
        out->sub_key.sub[i] = get16(p + TINY_SUB_FIXED_SIZE + TINY_SUBKEY_SIZE * i);
      return TINY_DECODE_OK;
    case TINY_FRAME_BEACON:
      if (plen < TINY_BEACON_SIZE) return TINY_DECODE_TRUNCATED;
      if (plen > TINY_BEACON_SIZE) return TINY_DECODE_BAD_LENGTH;
      if (out->src == TINY_ID_NONE || out->src == TINY_ID_BROADCAST) return TINY_DECODE_BAD_SRC;
      out->beacon_flags = p[0];
      out->beacon_tuples = p[1];
      out->beacon_uptime_ms = get32(p + 2);
      return TINY_DECODE_OK;
    default:
      return TINY_DECODE_UNKNOWN_TYPE;
  }
}

tiny_decode_result tiny_decode_frame(const uint8_t *buf, size_t len, tiny_frame *out,
                                     tiny_stats *stats) {
  tiny_decode_result r = decode(buf, len, out);
  if (stats == NULL) return r;
  ++stats->frames_rx;
  switch (r) {
    case TINY_DECODE_OK:
      ++stats->frames_ok;
      break;
    case TINY_DECODE_TRUNCATED:
      ++stats->drop_truncated;
      break;
    case TINY_DECODE_BAD_LENGTH:
      ++stats->drop_bad_length;
      break;
    case TINY_DECODE_BAD_VERSION:
      ++stats->drop_bad_version;
      break;
    case TINY_DECODE_UNKNOWN_TYPE:
      ++stats->drop_unknown_type;
      break;
    case TINY_DECODE_TOO_MANY_SUBKEYS:
      ++stats->drop_too_many_subkeys;
      break;
    case TINY_DECODE_BAD_KEY:
      ++stats->drop_bad_key;
      break;
    case TINY_DECODE_DATA_TOO_LONG:
      ++stats->drop_data_too_long;
      break;
    case TINY_DECODE_BAD_SRC:
      ++stats->drop_bad_src;
      break;
  }
  return r;
}
