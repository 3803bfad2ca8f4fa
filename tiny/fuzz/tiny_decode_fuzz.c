/* libFuzzer target for the tiny frame decoder (run by CTest as fault:tiny-fuzz,
 * through tests/fuzz/run_fuzz.sh BUILD_DIR tiny); by hand:
 *
 *   clang -std=c99 -g -fsanitize=fuzzer,address,undefined -I../include \
 *     tiny_decode_fuzz.c ../src/tiny_tuple.c -o tiny_decode_fuzz && ./tiny_decode_fuzz
 *
 * Every input decodes or is counted under exactly one drop reason, and a
 * decoded tuple re-encodes to the same bytes. */
#include <stdlib.h>
#include <string.h>

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
      if (n != size || memcmp(out, data, n) != 0) abort();
    }
    if (s.frames_ok != 1) abort();
  } else if (s.frames_ok != 0 || s.frames_rx != 1) {
    abort();
  }
  return 0;
}
