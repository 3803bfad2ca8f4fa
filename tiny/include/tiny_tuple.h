/* The tiny tuple and the radio frames of the Tiny PEIS-kernel (C99, no heap).
 *
 * This header is the protocol: the bridge includes it too. The byte layouts
 * are written down in docs/tiny-tuple.md; every size and offset is checked
 * below with a static assertion. All multi-byte integers on the radio are
 * LITTLE-ENDIAN (the byte order of 802.15.4 and of the AVR and Cortex-M
 * targets). Encoding and decoding work byte by byte on arrays and never
 * depend on the layout of a C struct in memory.
 *
 * The tiny tuple (92 bytes = 22-byte header + 70-byte storage):
 *
 *   off size field      meaning
 *   0   2    owner      PEIS id of the owner (1..0xFFFE)
 *   2   2    creator    PEIS id of the writer (== owner for own tuples)
 *   4   4    seqno      owner's write counter for this key, ordered with
 *                       serial-number arithmetic (newer if (int32)(a-b) > 0)
 *   8   4    ts_write   owner's millisecond clock at the write (wraps ~49.7 d)
 *   12  4    ts_user    application timestamp, opaque to the kernel
 *   16  4    ts_expire  lifetime in ms after ts_write; 0 = never expires
 *   20  1    key_len    number of 2-byte sub-keys, 1..7
 *   21  1    data_len   number of data bytes, 0..68, 2*key_len+data_len <= 70
 *   22  70   storage    key_len sub-keys (u16 each), then data_len bytes
 *
 * On the radio a tuple takes 22 + 2*key_len + data_len bytes (the unused
 * tail of the storage field is not sent). In RAM it takes exactly 92 bytes.
 */
#ifndef TINY_TUPLE_H
#define TINY_TUPLE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#define TINY_STATIC_ASSERT(cond, msg) static_assert(cond, msg)
#else
/* _Static_assert is C11; __extension__ keeps -std=c99 -Wpedantic quiet. */
#define TINY_STATIC_ASSERT(cond, msg) __extension__ _Static_assert(cond, msg)
#endif

/* ---- limits ---------------------------------------------------------- */
#define TINY_TUPLE_HEADER_SIZE 22
#define TINY_TUPLE_STORAGE_SIZE 70
#define TINY_TUPLE_SIZE (TINY_TUPLE_HEADER_SIZE + TINY_TUPLE_STORAGE_SIZE) /* 92 */
#define TINY_MAX_SUBKEYS 7
#define TINY_SUBKEY_SIZE 2
#define TINY_MAX_KEY_BYTES (TINY_MAX_SUBKEYS * TINY_SUBKEY_SIZE)   /* 14 */
#define TINY_MAX_DATA (TINY_TUPLE_STORAGE_SIZE - TINY_SUBKEY_SIZE) /* 68 */

/* Byte offsets of the tiny tuple header fields. */
#define TINY_OFF_OWNER 0
#define TINY_OFF_CREATOR 2
#define TINY_OFF_SEQNO 4
#define TINY_OFF_TS_WRITE 8
#define TINY_OFF_TS_USER 12
#define TINY_OFF_TS_EXPIRE 16
#define TINY_OFF_KEY_LEN 20
#define TINY_OFF_DATA_LEN 21
#define TINY_OFF_STORAGE 22

/* Special node ids. */
#define TINY_ID_NONE 0x0000u      /* never a node */
#define TINY_ID_BROADCAST 0xFFFFu /* frame destination: every node */
#define TINY_ANY_OWNER 0xFFFFu    /* subscription owner: any PEIS */

/* ---- radio frames ------------------------------------------------------ */
/* Every frame: an 8-byte header, then a payload whose layout the type fixes.
 *
 *   off size field
 *   0   1    type      TINY_FRAME_*
 *   1   1    version   TINY_PROTOCOL_VERSION
 *   2   2    src       sender's node id
 *   4   2    dst       receiver's node id, or TINY_ID_BROADCAST
 *   6   2    seq       sender's frame counter (wraps), for diagnostics and
 *                      duplicate detection by a base station
 *   8   ...  payload
 */
#define TINY_PROTOCOL_VERSION 1
#define TINY_FRAME_MAX 100
#define TINY_FRAME_HEADER_SIZE 8
#define TINY_FRAME_PAYLOAD_MAX (TINY_FRAME_MAX - TINY_FRAME_HEADER_SIZE) /* 92 */

/* ---- secured frames (docs/tiny-tuple.md, docs/security.md) ------------
 * On a secured radio every frame has version TINY_SECURED_VERSION and ends
 * in a 12-byte trailer:
 *
 *   off     size field
 *   len-12  4    counter   the sender's frame counter, little-endian,
 *                          strictly increasing (never reused, restarts
 *                          included: it is kept in non-volatile memory)
 *   len-8   8    mac       SipHash-2-4 under the sender's 16-byte key over
 *                          every byte before it
 *
 * A receiver takes a frame only from a sender whose key it holds, with a
 * MAC that checks and a counter above the last one it took from it. The
 * trailer leaves 58 bytes of key and data in a tuple (70 - 12). */
#define TINY_SECURED_VERSION 2
#define TINY_COUNTER_SIZE 4
#define TINY_MAC_SIZE 8
#define TINY_SECURED_OVERHEAD (TINY_COUNTER_SIZE + TINY_MAC_SIZE) /* 12 */
#define TINY_MAC_KEY_SIZE 16
#define TINY_SECURED_STORAGE (TINY_TUPLE_STORAGE_SIZE - TINY_SECURED_OVERHEAD) /* 58 */

#define TINY_FOFF_TYPE 0
#define TINY_FOFF_VERSION 1
#define TINY_FOFF_SRC 2
#define TINY_FOFF_DST 4
#define TINY_FOFF_SEQ 6
#define TINY_FOFF_PAYLOAD 8

typedef enum tiny_frame_type {
  /* payload: one encoded tuple, 22 + 2*key_len + data_len bytes. */
  TINY_FRAME_TUPLE = 1,
  /* payload: owner u16 (or TINY_ANY_OWNER), flags u8 (TINY_SUB_PREFIX),
   * key_len u8 (0..7; 0 only with TINY_SUB_PREFIX), key_len sub-keys. */
  TINY_FRAME_SUBSCRIBE = 2,
  /* payload: as TINY_FRAME_SUBSCRIBE. */
  TINY_FRAME_UNSUBSCRIBE = 3,
  /* payload: flags u8, tuple count u8, uptime ms u32 (6 bytes). */
  TINY_FRAME_BEACON = 4,
  /* payload: one encoded tuple, as TINY_FRAME_TUPLE: a request to the
   * tuple's owner (the frame's dst) to set its own tuple to this key and
   * data; creator names the writer. The owner stamps its own seqno and
   * ts_write and sends the result to its subscribers as usual (that tuple
   * frame is the acknowledgement). */
  TINY_FRAME_WRITE = 5
} tiny_frame_type;

#define TINY_SUB_PREFIX 0x01u /* the key is a prefix: matches longer keys */
#define TINY_SUB_FLAGS_KNOWN TINY_SUB_PREFIX
#define TINY_SUB_FIXED_SIZE 4 /* owner, flags, key_len */
#define TINY_BEACON_SIZE 6
#define TINY_BEACON_TINY 0x01u /* beacon flag: the sender is a tiny node */

/* ---- in-memory types --------------------------------------------------- */

/* A key: up to 7 integer sub-keys. */
typedef struct tiny_key {
  uint8_t len;
  uint16_t sub[TINY_MAX_SUBKEYS];
} tiny_key;

/* A tiny tuple in RAM: 92 bytes, the header fields followed by the storage
 * field (sub-keys little-endian, then the data), byte-identical to what the
 * radio carries. Use the accessors below instead of touching storage. */
typedef struct tiny_tuple {
  uint16_t owner;
  uint16_t creator;
  uint32_t seqno;
  uint32_t ts_write;
  uint32_t ts_user;
  uint32_t ts_expire;
  uint8_t key_len;
  uint8_t data_len;
  uint8_t storage[TINY_TUPLE_STORAGE_SIZE];
} tiny_tuple;

/* One decoded frame. For a tuple frame `tuple` is filled; for (un)subscribe
 * `sub_owner`, `sub_flags` and `sub_key`; for a beacon the `beacon_*`. */
typedef struct tiny_frame {
  uint8_t type;
  uint16_t src;
  uint16_t dst;
  uint16_t seq;
  tiny_tuple tuple;
  uint16_t sub_owner;
  uint8_t sub_flags;
  tiny_key sub_key;
  uint8_t beacon_flags;
  uint8_t beacon_tuples;
  uint32_t beacon_uptime_ms;
} tiny_frame;

/* A counter of tiny_stats: 32 bits, or 16 with TINY_STATS_16 (the
 * ATmega128 port: 52 bytes of RAM less; they wrap at 65,535). */
#ifdef TINY_STATS_16
typedef uint16_t tiny_count;
#else
typedef uint32_t tiny_count;
#endif

/* Counters of a decoder (and of a kernel, which embeds one). Every frame
 * that is dropped is counted under exactly one drop reason. */
typedef struct tiny_stats {
  tiny_count frames_rx;             /* frames handed to the decoder */
  tiny_count frames_ok;             /* frames that decoded */
  tiny_count frames_tx;             /* frames sent (kernel) */
  tiny_count send_errors;           /* HAL send failures (kernel) */
  tiny_count drop_truncated;        /* shorter than its header or declared fields */
  tiny_count drop_bad_length;       /* longer than declared, or over 100 bytes */
  tiny_count drop_bad_version;      /* version byte is not ours */
  tiny_count drop_unknown_type;     /* type byte is not a TINY_FRAME_* */
  tiny_count drop_too_many_subkeys; /* key_len > 7 */
  tiny_count drop_bad_key;          /* tuple key_len 0, or unknown sub flags */
  tiny_count drop_data_too_long;    /* data_len > 68, or key + data > 70 */
  tiny_count drop_bad_src;          /* src is 0 or broadcast */
  /* kernel-level outcomes of frames that decoded */
  tiny_count tuples_accepted;  /* new value in the cache, callbacks ran */
  tiny_count tuples_stale;     /* seqno not newer than the cached one */
  tiny_count tuples_unwanted;  /* no local subscription matches */
  tiny_count not_for_me;       /* addressed to another node */
  tiny_count cache_full;       /* wanted remote tuple, no room in the cache */
  tiny_count subscribers_full; /* new subscriber, no room in the table */
  tiny_count neighbors_full;   /* new neighbour, no room in the table */
  tiny_count writes_accepted;  /* write requests applied to own tuples */
  tiny_count writes_refused;   /* write requests for another owner, or no free slot */
  /* a secured radio (tiny_kernel.h, tiny_secure) */
  tiny_count drop_unsecured;      /* not a secured frame */
  tiny_count drop_unknown_sender; /* a sender whose key this node does not hold */
  tiny_count drop_bad_mac;        /* its MAC does not check */
  tiny_count drop_replay;         /* its counter is not above the last one taken */
  tiny_count drop_forged_owner;   /* a node's frame with another's tuple */
} tiny_stats;

/* Decode results; TINY_DECODE_OK is 0, the others name the drop reason. */
typedef enum tiny_decode_result {
  TINY_DECODE_OK = 0,
  TINY_DECODE_TRUNCATED,
  TINY_DECODE_BAD_LENGTH,
  TINY_DECODE_BAD_VERSION,
  TINY_DECODE_UNKNOWN_TYPE,
  TINY_DECODE_TOO_MANY_SUBKEYS,
  TINY_DECODE_BAD_KEY,
  TINY_DECODE_DATA_TOO_LONG,
  TINY_DECODE_BAD_SRC
} tiny_decode_result;

/* ---- static checks ----------------------------------------------------- */
TINY_STATIC_ASSERT(TINY_TUPLE_HEADER_SIZE == 22, "tiny tuple header is 22 bytes");
TINY_STATIC_ASSERT(TINY_TUPLE_STORAGE_SIZE == 70, "tiny tuple storage is 70 bytes");
TINY_STATIC_ASSERT(TINY_TUPLE_SIZE == 92, "tiny tuple is 92 bytes");
TINY_STATIC_ASSERT(TINY_MAX_KEY_BYTES == 14, "key is at most 14 bytes");
TINY_STATIC_ASSERT(TINY_MAX_DATA == 68, "data is at most 68 bytes");
TINY_STATIC_ASSERT(TINY_OFF_CREATOR == TINY_OFF_OWNER + 2, "owner is u16");
TINY_STATIC_ASSERT(TINY_OFF_SEQNO == TINY_OFF_CREATOR + 2, "creator is u16");
TINY_STATIC_ASSERT(TINY_OFF_TS_WRITE == TINY_OFF_SEQNO + 4, "seqno is u32");
TINY_STATIC_ASSERT(TINY_OFF_TS_USER == TINY_OFF_TS_WRITE + 4, "ts_write is u32");
TINY_STATIC_ASSERT(TINY_OFF_TS_EXPIRE == TINY_OFF_TS_USER + 4, "ts_user is u32");
TINY_STATIC_ASSERT(TINY_OFF_KEY_LEN == TINY_OFF_TS_EXPIRE + 4, "ts_expire is u32");
TINY_STATIC_ASSERT(TINY_OFF_DATA_LEN == TINY_OFF_KEY_LEN + 1, "key_len is u8");
TINY_STATIC_ASSERT(TINY_OFF_STORAGE == TINY_OFF_DATA_LEN + 1, "data_len is u8");
TINY_STATIC_ASSERT(TINY_OFF_STORAGE == TINY_TUPLE_HEADER_SIZE, "storage follows the header");
TINY_STATIC_ASSERT(sizeof(tiny_tuple) == TINY_TUPLE_SIZE, "a tuple takes 92 bytes of RAM");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, owner) == TINY_OFF_OWNER, "owner offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, creator) == TINY_OFF_CREATOR, "creator offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, seqno) == TINY_OFF_SEQNO, "seqno offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, ts_write) == TINY_OFF_TS_WRITE, "ts_write offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, ts_user) == TINY_OFF_TS_USER, "ts_user offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, ts_expire) == TINY_OFF_TS_EXPIRE, "ts_expire offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, key_len) == TINY_OFF_KEY_LEN, "key_len offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, data_len) == TINY_OFF_DATA_LEN, "data_len offset");
TINY_STATIC_ASSERT(offsetof(tiny_tuple, storage) == TINY_OFF_STORAGE, "storage offset");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE == 8, "frame header is 8 bytes");
TINY_STATIC_ASSERT(TINY_FOFF_PAYLOAD == TINY_FRAME_HEADER_SIZE, "payload follows the header");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE + TINY_TUPLE_SIZE <= TINY_FRAME_MAX,
                   "the largest tuple fits one frame");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE + TINY_SUB_FIXED_SIZE + TINY_MAX_KEY_BYTES <=
                       TINY_FRAME_MAX,
                   "the largest subscription fits one frame");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE + TINY_BEACON_SIZE <= TINY_FRAME_MAX,
                   "a beacon fits one frame");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE + TINY_TUPLE_HEADER_SIZE + TINY_SECURED_STORAGE +
                           TINY_SECURED_OVERHEAD ==
                       TINY_FRAME_MAX,
                   "the largest secured tuple fits one frame exactly");
TINY_STATIC_ASSERT(TINY_FRAME_HEADER_SIZE + TINY_SUB_FIXED_SIZE + TINY_MAX_KEY_BYTES +
                           TINY_SECURED_OVERHEAD <=
                       TINY_FRAME_MAX,
                   "the largest secured subscription fits one frame");

/* ---- functions --------------------------------------------------------- */

/* A one-sub-key key. */
tiny_key tiny_key1(uint16_t sub0);
/* Whether two keys are equal. */
int tiny_key_equal(const tiny_key *a, const tiny_key *b);

/* Sub-key i of a tuple (0 if out of range), its key, its data. */
uint16_t tiny_tuple_subkey(const tiny_tuple *t, uint8_t i);
void tiny_tuple_key(const tiny_tuple *t, tiny_key *out);
const uint8_t *tiny_tuple_data(const tiny_tuple *t);

/* Fills key and data of `t` (other fields untouched). Returns 0, or -1 if
 * the key has 0 or more than 7 sub-keys, data is over 68 bytes or key and
 * data together exceed the 70-byte storage. */
int tiny_tuple_set_key_data(tiny_tuple *t, const tiny_key *key, const void *data, uint8_t data_len);

/* Encoded size of a tuple on the radio: 22 + 2*key_len + data_len. */
size_t tiny_tuple_wire_size(const tiny_tuple *t);

/* Encodes `t` into buf. Returns the number of bytes written, or 0 if the
 * tuple is invalid or cap is too small. */
size_t tiny_tuple_encode(const tiny_tuple *t, uint8_t *buf, size_t cap);

/* Decodes exactly `len` bytes into *out (the unused storage tail zeroed). */
tiny_decode_result tiny_tuple_decode(const uint8_t *buf, size_t len, tiny_tuple *out);

/* Frame encoders: write the 8-byte header and the payload into buf (at
 * least TINY_FRAME_MAX bytes). Return the frame length, or 0 on bad input. */
size_t tiny_encode_tuple_frame(uint8_t *buf, uint16_t src, uint16_t dst, uint16_t seq,
                               const tiny_tuple *t);
/* A write request to t->owner (dst is t->owner). */
size_t tiny_encode_write_frame(uint8_t *buf, uint16_t src, uint16_t seq, const tiny_tuple *t);
size_t tiny_encode_sub_frame(uint8_t *buf, uint8_t type, uint16_t src, uint16_t dst, uint16_t seq,
                             uint16_t owner, uint8_t flags, const tiny_key *key);
size_t tiny_encode_beacon_frame(uint8_t *buf, uint16_t src, uint16_t seq, uint8_t flags,
                                uint8_t tuples, uint32_t uptime_ms);

/* Decodes one received frame of `len` bytes. Checks every length; on
 * failure returns the reason and counts it in *stats (which may be NULL).
 * Total: any bytes, any length, never reads outside buf[0..len). */
tiny_decode_result tiny_decode_frame(const uint8_t *buf, size_t len, tiny_frame *out,
                                     tiny_stats *stats);

#ifdef __cplusplus
}
#endif

#endif /* TINY_TUPLE_H */
