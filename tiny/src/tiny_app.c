/* Helpers shared by the device programs: decimal text without stdio. */
#include "tiny_app.h"

uint8_t tiny_format_long(long v, char *buf, uint8_t cap) {
  char tmp[12];
  uint8_t n = 0, out = 0;
  unsigned long u = v < 0 ? 0ul - (unsigned long)v : (unsigned long)v;
  do {
    tmp[n++] = (char)('0' + (u % 10u));
    u /= 10u;
  } while (u != 0 && n < sizeof tmp - 1);
  if (v < 0) tmp[n++] = '-';
  if (n > cap) return 0;
  while (n > 0) buf[out++] = tmp[--n];
  return out;
}

int tiny_set_long(tiny_kernel *k, uint16_t key, long v) {
  char text[12];
  tiny_key k1 = tiny_key1(key);
  uint8_t n = tiny_format_long(v, text, sizeof text);
  return tiny_set(k, &k1, text, n);
}

int tiny_parse_long(const uint8_t *data, uint8_t len, long *out) {
  uint8_t i = 0;
  int neg = 0;
  long v = 0;
  if (len == 0 || len > 11) return -1;
  if (data[0] == '-') {
    neg = 1;
    i = 1;
    if (len == 1) return -1;
  }
  for (; i < len; ++i) {
    if (data[i] < '0' || data[i] > '9') return -1;
    v = v * 10 + (data[i] - '0');
  }
  *out = neg ? -v : v;
  return 0;
}
