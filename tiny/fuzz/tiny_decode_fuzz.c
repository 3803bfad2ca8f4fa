/* libFuzzer target for the tiny frame decoder (run by CTest as fault:tiny-fuzz,
 * through tests/fuzz/run_fuzz.sh BUILD_DIR tiny); by hand:
 *
 *   clang -std=c99 -g -fsanitize=fuzzer,address,undefined -I../include \
 *     tiny_decode_fuzz.c ../src/tiny_tuple.c ../src/tiny_mac.c -o tiny_decode_fuzz && \
 *     ./tiny_decode_fuzz
 *
 * Every input decodes or is counted under exactly one drop reason, and a
 * decoded tuple re-encodes to the same bytes (the version byte as given: a
 * secured frame's inner bytes decode too). Every input also goes through
 * the secured radio's checks (tiny_mac.h), which must never read outside
 * it and never take it for authentic under a key it was not sealed with. */
#include <stdlib.h>
#include <string.h>

#include "tiny_mac.h"
#include "tiny_tuple.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  tiny_stats s;
  tiny_frame f;
  uint8_t out[TINY_FRAME_MAX];
  memset(&s, 0, sizeof s);
  if (tiny_decode_frame(data, size, &f, &s) == TINY_DECODE_OK) {
    if (f.type == TINY_FRAME_TUPLE) {
      size_t n = tiny_encode_tuple_frame(out, f.src, f.dst, f.seq, &f.tuple);
      if (n == size) out[TINY_FOFF_VERSION] = data[TINY_FOFF_VERSION];
      if (n != size || memcmp(out, data, n) != 0) abort();
    }
    if (s.frames_ok != 1) abort();
  } else if (s.frames_ok != 0 || s.frames_rx != 1) {
    abort();
  }
  {
    static const uint8_t key[TINY_MAC_KEY_SIZE] = {7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7};
    uint8_t sealed[TINY_FRAME_MAX];
    size_t n;
    (void)tiny_frame_counter(data, size);
    (void)tiny_frame_mac_ok(data, size, key); /* any bytes: never out of bounds */
    /* A frame sealed here checks under its key, and no longer once changed. */
    if (size >= TINY_FRAME_HEADER_SIZE && size + TINY_SECURED_OVERHEAD <= TINY_FRAME_MAX) {
      memcpy(sealed, data, size);
      n = tiny_seal_frame(sealed, size, key, (uint32_t)size);
      if (n != size + TINY_SECURED_OVERHEAD || !tiny_frame_mac_ok(sealed, n, key)) abort();
      sealed[n - 1] ^= 1u;
      if (tiny_frame_mac_ok(sealed, n, key)) abort();
    }
  }
  return 0;
}
