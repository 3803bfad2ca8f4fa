/* The run-time support a freestanding clang --target=msp430 build needs,
 * since no MSP430 C library or compiler-rt is installed: the <string.h>
 * functions of libc/string.h and the MSP430 EABI helpers that clang calls
 * for 32-bit multiplication, division and variable shifts (the MSP430 has
 * no divide instruction and shifts one bit at a time).
 *
 * Everything here is written with additions, subtractions, comparisons and
 * one-bit shifts only, so that compiling it never calls these helpers
 * back. -ffreestanding keeps clang from turning the loops into memset or
 * memcpy calls. Unused functions are dropped by --gc-sections.
 */
#include <stdint.h>
#include <string.h>

void *memcpy(void *restrict dst, const void *restrict src, size_t n) {
  uint8_t *d = dst;
  const uint8_t *s = src;
  while (n--) *d++ = *s++;
  return dst;
}

void *memset(void *dst, int c, size_t n) {
  uint8_t *d = dst;
  while (n--) *d++ = (uint8_t)c;
  return dst;
}

void *memmove(void *dst, const void *src, size_t n) {
  uint8_t *d = dst;
  const uint8_t *s = src;
  if (d < s) {
    while (n--) *d++ = *s++;
  } else {
    while (n--) d[n] = s[n];
  }
  return dst;
}

int memcmp(const void *a, const void *b, size_t n) {
  const uint8_t *p = a, *q = b;
  for (; n--; ++p, ++q) {
    if (*p != *q) return *p < *q ? -1 : 1;
  }
  return 0;
}

size_t strlen(const char *s) {
  size_t n = 0;
  while (s[n] != '\0') ++n;
  return n;
}

/* ---- MSP430 EABI helpers (names and C calling convention of the EABI:
 * arguments in R12..R15, result in R12(:R13)). --------------------------- */
uint16_t __mspabi_mpyi(uint16_t a, uint16_t b);
uint16_t __mspabi_mpyi_hw(uint16_t a, uint16_t b);
uint32_t __mspabi_mpyl(uint32_t a, uint32_t b);
uint32_t __mspabi_mpyl_hw(uint32_t a, uint32_t b);
uint16_t __mspabi_divu(uint16_t a, uint16_t b);
uint16_t __mspabi_remu(uint16_t a, uint16_t b);
int16_t __mspabi_divi(int16_t a, int16_t b);
int16_t __mspabi_remi(int16_t a, int16_t b);
uint32_t __mspabi_divul(uint32_t a, uint32_t b);
uint32_t __mspabi_remul(uint32_t a, uint32_t b);
int32_t __mspabi_divli(int32_t a, int32_t b);
int32_t __mspabi_remli(int32_t a, int32_t b);
uint32_t __mspabi_slll(uint32_t a, int16_t n);
uint32_t __mspabi_srll(uint32_t a, int16_t n);
int32_t __mspabi_sral(int32_t a, int16_t n);

uint16_t __mspabi_mpyi(uint16_t a, uint16_t b) {
  uint16_t r = 0;
  while (b != 0) {
    if (b & 1u) r = (uint16_t)(r + a);
    a = (uint16_t)(a + a);
    b >>= 1;
  }
  return r;
}
/* The _hw variants may use the hardware multiplier; the software loop
 * gives the same results (and no interrupt-safety issue with MPY). */
uint16_t __mspabi_mpyi_hw(uint16_t a, uint16_t b) { return __mspabi_mpyi(a, b); }

uint32_t __mspabi_mpyl(uint32_t a, uint32_t b) {
  uint32_t r = 0;
  while (b != 0) {
    if (b & 1u) r += a;
    a += a;
    b >>= 1;
  }
  return r;
}
uint32_t __mspabi_mpyl_hw(uint32_t a, uint32_t b) { return __mspabi_mpyl(a, b); }

/* Restoring division; *rem gets the remainder. Division by 0 gives an
 * all-ones quotient and the dividend as remainder (C leaves it undefined). */
static uint32_t udiv32(uint32_t n, uint32_t d, uint32_t *rem) {
  uint32_t q = 0, r = 0;
  uint8_t i;
  for (i = 0; i < 32; ++i) {
    r = (r << 1) | ((n & 0x80000000ul) ? 1u : 0u);
    n <<= 1;
    q <<= 1;
    if (r >= d && d != 0) {
      r -= d;
      q |= 1u;
    }
  }
  if (d == 0) {
    q = 0xFFFFFFFFul;
    r = n;
  }
  *rem = r;
  return q;
}

uint32_t __mspabi_divul(uint32_t a, uint32_t b) {
  uint32_t r;
  return udiv32(a, b, &r);
}
uint32_t __mspabi_remul(uint32_t a, uint32_t b) {
  uint32_t r;
  (void)udiv32(a, b, &r);
  return r;
}
uint16_t __mspabi_divu(uint16_t a, uint16_t b) { return (uint16_t)__mspabi_divul(a, b); }
uint16_t __mspabi_remu(uint16_t a, uint16_t b) { return (uint16_t)__mspabi_remul(a, b); }

/* Signed: truncation toward zero, remainder with the dividend's sign. */
int32_t __mspabi_divli(int32_t a, int32_t b) {
  uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
  uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
  uint32_t q = __mspabi_divul(ua, ub);
  return (int32_t)((a < 0) != (b < 0) ? 0u - q : q);
}
int32_t __mspabi_remli(int32_t a, int32_t b) {
  uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
  uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
  uint32_t r = __mspabi_remul(ua, ub);
  return (int32_t)(a < 0 ? 0u - r : r);
}
int16_t __mspabi_divi(int16_t a, int16_t b) { return (int16_t)__mspabi_divli(a, b); }
int16_t __mspabi_remi(int16_t a, int16_t b) { return (int16_t)__mspabi_remli(a, b); }

uint32_t __mspabi_slll(uint32_t a, int16_t n) {
  while (n-- > 0) a <<= 1;
  return a;
}
uint32_t __mspabi_srll(uint32_t a, int16_t n) {
  while (n-- > 0) a >>= 1;
  return a;
}
int32_t __mspabi_sral(int32_t a, int16_t n) {
  while (n-- > 0) a = (int32_t)(((uint32_t)a >> 1) | ((uint32_t)a & 0x80000000ul));
  return a;
}
