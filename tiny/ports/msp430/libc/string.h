/* The MSP430 port is built freestanding (clang --target=msp430, no C
 * library installed): this is the part of <string.h> the tiny kernel
 * uses. The functions are in runtime.c. */
#ifndef TINY_MSP430_STRING_H
#define TINY_MSP430_STRING_H

#include <stddef.h>

void *memcpy(void *restrict dst, const void *restrict src, size_t n);
void *memset(void *dst, int c, size_t n);
void *memmove(void *dst, const void *src, size_t n);
int memcmp(const void *a, const void *b, size_t n);
size_t strlen(const char *s);

#endif /* TINY_MSP430_STRING_H */
