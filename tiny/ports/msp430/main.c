/* The MSP430F1611 port (the TelosB's MCU: 48 KB flash, 10 KB RAM), built
 * freestanding with clang --target=msp430 and ld.lld (build.sh): runs one
 * device program (linked beside this file) as a tiny node whose radio is an
 * XBee-like serial radio on USART1 (P3.6 TX, P3.7 RX; the TelosB's USB
 * serial line), with the framing of the other ports (tiny_serial.h).
 *
 *  - USART1: UART 9600 8N1 clocked from ACLK (the 32768 Hz watch crystal:
 *    exact without calibrating the DCO; 9600 is the XBee's default rate),
 *    interrupt-driven reception into a ring buffer, polled transmission;
 *  - clock: Timer A from ACLK, 1024 interrupts a second, turned into
 *    milliseconds (1000/1024 ms per tick, no drift);
 *  - CPU: the DCO at its highest range step (about 4 MHz, uncalibrated;
 *    nothing depends on its exact rate);
 *  - tiny_port_report keeps the last value in msp430_last_report and
 *    toggles LED1 (P5.4, active low on the TelosB); tiny_port_sensor
 *    returns constants (TINY_MSP430_LIGHT, TINY_MSP430_WEIGHT).
 *
 * Startup (stack pointer, watchdog, .data copy, .bss zeroing) and the
 * interrupt vectors (sections __interrupt_vector_N, placed at 0xFFE0 + 2N by
 * msp430f1611.ld) are in this file; runtime.c has memcpy/memset and the
 * EABI arithmetic helpers. The register addresses are those of the MSP430x1xx
 * family user's guide and the MSP430F1611 data sheet (no TI headers needed).
 */
#include <stdint.h>

#include "tiny_app.h"
#include "tiny_serial.h"

#ifndef TINY_MSP430_LIGHT
#define TINY_MSP430_LIGHT 500
#endif
#ifndef TINY_MSP430_WEIGHT
#define TINY_MSP430_WEIGHT 1250
#endif
#define RX_RING 64u

#define REG8(addr) (*(volatile uint8_t *)(addr))
#define REG16(addr) (*(volatile uint16_t *)(addr))
/* special function registers */
#define IE2 REG8(0x0001u)
#define ME2 REG8(0x0005u)
#define URXIE1 0x10u
#define UTXE1 0x20u
#define URXE1 0x10u
#define IFG2 REG8(0x0003u)
#define UTXIFG1 0x20u
/* ports */
#define P3SEL REG8(0x001Bu)
#define P5OUT REG8(0x0031u)
#define P5DIR REG8(0x0032u)
#define LED1 0x10u /* P5.4 */
/* basic clock */
#define DCOCTL REG8(0x0056u)
#define BCSCTL1 REG8(0x0057u)
/* USART1 in UART mode */
#define U1CTL REG8(0x0078u)
#define U1TCTL REG8(0x0079u)
#define U1RCTL REG8(0x007Au)
#define U1MCTL REG8(0x007Bu)
#define U1BR0 REG8(0x007Cu)
#define U1BR1 REG8(0x007Du)
#define U1RXBUF REG8(0x007Eu)
#define U1TXBUF REG8(0x007Fu)
#define CHAR 0x10u
#define SWRST 0x01u
#define SSEL_ACLK 0x10u
/* watchdog */
#define WDTCTL REG16(0x0120u)
#define WDTPW_HOLD 0x5A80u
/* Timer A */
#define TACTL REG16(0x0160u)
#define TACCTL0 REG16(0x0162u)
#define TACCR0 REG16(0x0172u)
#define TASSEL_ACLK 0x0100u
#define MC_UP 0x0010u
#define TACLR 0x0004u
#define CCIE 0x0010u
/* interrupt vector numbers (address 0xFFE0 + 2N) */
#define USART1RX_VECTOR 3
#define TIMERA0_VECTOR 6
#define RESET_VECTOR 15

static volatile uint32_t clock_ms;
static volatile uint16_t clock_frac; /* in 1/1024 ms */
static volatile uint8_t ring_bytes[RX_RING];
static tiny_serial_ring ring = {ring_bytes, RX_RING - 1u, 0, 0, 0};
static tiny_serial_rx decoder;
static tiny_kernel kernel;
volatile long msp430_last_report;

/* 1024 Hz: each tick is 1000/1024 ms. */
__attribute__((interrupt(TIMERA0_VECTOR))) void timer_a0_isr(void) {
  clock_frac = (uint16_t)(clock_frac + 1000u);
  if (clock_frac >= 1024u) {
    clock_frac = (uint16_t)(clock_frac - 1024u);
    ++clock_ms;
  }
}

__attribute__((interrupt(USART1RX_VECTOR))) void usart1_rx_isr(void) {
  tiny_serial_ring_put(&ring, U1RXBUF); /* reading U1RXBUF clears URXIFG1 */
}

static uint32_t now_ms(void *ctx) {
  uint16_t sr;
  uint32_t v;
  (void)ctx;
  /* A 32-bit read takes two instructions on this 16-bit CPU. */
  __asm__ volatile("mov r2, %0\n\tdint\n\tnop" : "=r"(sr) : : "memory");
  v = clock_ms;
  if (sr & 0x0008u) __asm__ volatile("eint" : : : "memory"); /* GIE was set */
  return v;
}

static void put_byte(uint8_t b) {
  while (!(IFG2 & UTXIFG1)) {
  }
  U1TXBUF = b;
}

static tiny_serial_port uart = {put_byte, &ring, &decoder};

/* 9600 8N1 from ACLK = 32768 Hz: UBR = 3, modulation 0x4A (user's guide). */
static void uart_init(void) {
  U1CTL = CHAR | SWRST;
  U1TCTL = SSEL_ACLK;
  U1BR0 = 0x03u;
  U1BR1 = 0x00u;
  U1MCTL = 0x4Au;
  U1RCTL = 0;
  P3SEL |= 0xC0u; /* P3.6 UTXD1, P3.7 URXD1 */
  ME2 |= UTXE1 | URXE1;
  U1CTL &= (uint8_t)~SWRST;
  IE2 |= URXIE1;
  tiny_serial_rx_init(&decoder);
}

static void clock_init(void) {
  BCSCTL1 = (uint8_t)((BCSCTL1 & ~0x07u) | 0x07u); /* RSEL 7 */
  DCOCTL = 0x60u;                                  /* DCO 3, no modulation */
  TACCR0 = 32u - 1u;                               /* 32768 / 32 = 1024 Hz */
  TACCTL0 = CCIE;
  TACTL = TASSEL_ACLK | MC_UP | TACLR;
}

void tiny_port_report(const char *event, long value) {
  (void)event;
  msp430_last_report = value;
  P5OUT ^= LED1;
}

long tiny_port_sensor(uint8_t channel) {
  switch (channel) {
    case TINY_SENSOR_LIGHT:
      return TINY_MSP430_LIGHT;
    case TINY_SENSOR_WEIGHT:
      return TINY_MSP430_WEIGHT;
    default:
      return 0;
  }
}

int main(void) {
  tiny_hal hal;
  uint16_t id = tiny_port_node_id();
  P5DIR |= LED1;
  P5OUT |= LED1; /* off (active low) */
  clock_init();
  uart_init();
  __asm__ volatile("eint\n\tnop" : : : "memory");
  hal = tiny_serial_hal(&uart, now_ms);
  tiny_init(&kernel, id, &hal);
  app_setup(&kernel);
  for (;;) {
    uint32_t now = now_ms(0);
    tiny_poll(&kernel, now);
    app_loop(&kernel, now);
  }
}

/* ---- startup ------------------------------------------------------------ */
extern uint16_t _sidata[], _sdata[], _edata[], _sbss[], _ebss[];
void c_startup(void);

void c_startup(void) {
  uint16_t *src = _sidata, *dst = _sdata;
  while (dst < _edata) *dst++ = *src++;
  for (dst = _sbss; dst < _ebss;) *dst++ = 0;
  (void)main();
  for (;;) {
  }
}

/* The MSP430 does not load SP from the vector table: set it (the top of
 * RAM, _estack in msp430f1611.ld) and stop the watchdog before any C. */
__asm__(
    ".section .text.reset_handler,\"ax\",@progbits\n"
    ".global reset_handler\n"
    "reset_handler:\n"
    "\tmov #_estack, r1\n"
    "\tmov #0x5a80, &0x0120\n" /* WDTCTL = WDTPW | WDTHOLD */
    "\tbr #c_startup\n");
void reset_handler(void);

__attribute__((section("__interrupt_vector_15"),
               used)) static void (*const reset_vector)(void) = reset_handler;
