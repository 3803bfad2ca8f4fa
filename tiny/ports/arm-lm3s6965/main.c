/* The LM3S6965 port (Cortex-M3, the board qemu-system-arm emulates as
 * lm3s6965evb): runs one device program (linked beside this file) as a
 * tiny node whose radio is a serial radio on UART0, with the same framing
 * as the ATmega128 port (tiny_serial.h: 0x7E, LEN, frame, checksum).
 *
 *  - UART0: 115200 8N1, interrupt-driven reception into a ring buffer,
 *    polled transmission;
 *  - clock: SysTick every millisecond (TINY_ARM_CPU_HZ, 12 MHz after reset);
 *  - tiny_port_report keeps the last value in arm_last_report (no LED);
 *  - tiny_port_sensor returns constants (light TINY_ARM_LIGHT, weight
 *    TINY_ARM_WEIGHT): the emulated board has no sensors;
 *  - with -DTINY_ARM_RUN_MS=N (emulator builds only) the program stops
 *    after N ms through the semihosting SYS_EXIT call, so that
 *    `qemu-system-arm -semihosting-config enable=on,target=native` exits
 *    with status 0. Without it (the default) the program runs forever; do
 *    not set it for a real board, where BKPT halts the core or faults.
 *
 * Startup (vector table, .data copy, .bss zeroing) is in this file too.
 */
#include <stdint.h>

#include "tiny_app.h"
#include "tiny_serial.h"

#ifndef TINY_ARM_CPU_HZ
#define TINY_ARM_CPU_HZ 12000000ul
#endif
#ifndef TINY_ARM_BAUD
#define TINY_ARM_BAUD 115200ul
#endif
#ifndef TINY_ARM_LIGHT
#define TINY_ARM_LIGHT 500
#endif
#ifndef TINY_ARM_WEIGHT
#define TINY_ARM_WEIGHT 1250
#endif
#define RX_RING 128u

#define REG(addr) (*(volatile uint32_t *)(addr))
#define SYSCTL_RCGC1 REG(0x400FE104u)
#define SYSCTL_RCGC2 REG(0x400FE108u)
#define GPIOA_AFSEL REG(0x40004420u)
#define GPIOA_DEN REG(0x4000451Cu)
#define UART0_DR REG(0x4000C000u)
#define UART0_FR REG(0x4000C018u)
#define UART0_IBRD REG(0x4000C024u)
#define UART0_FBRD REG(0x4000C028u)
#define UART0_LCRH REG(0x4000C02Cu)
#define UART0_CTL REG(0x4000C030u)
#define UART0_IM REG(0x4000C038u)
#define UART0_ICR REG(0x4000C044u)
#define UART_FR_RXFE 0x10u
#define UART_FR_TXFF 0x20u
#define NVIC_ISER0 REG(0xE000E100u)
#define SYST_CSR REG(0xE000E010u)
#define SYST_RVR REG(0xE000E014u)
#define SYST_CVR REG(0xE000E018u)
#define UART0_IRQ 5u

static volatile uint32_t clock_ms;
static volatile uint8_t ring_bytes[RX_RING];
static tiny_serial_ring ring = {ring_bytes, RX_RING - 1u, 0, 0, 0};
static tiny_serial_rx decoder;
static tiny_kernel kernel;
volatile long arm_last_report;

void systick_handler(void) { ++clock_ms; }

void uart0_handler(void) {
  while (!(UART0_FR & UART_FR_RXFE)) {
    tiny_serial_ring_put(&ring, (uint8_t)UART0_DR);
  }
  UART0_ICR = 0x7F0u;
}

static uint32_t now_ms(void *ctx) {
  (void)ctx;
  return clock_ms; /* a 32-bit load is atomic on the Cortex-M3 */
}

static void put_byte(uint8_t b) {
  while (UART0_FR & UART_FR_TXFF) {
  }
  UART0_DR = b;
}

static tiny_serial_port uart = {put_byte, &ring, &decoder};

static void uart_init(void) {
  /* Baud divisor = CPU / (16 * baud), fraction in 1/64ths, rounded. */
  uint32_t div64 = (uint32_t)((4ul * TINY_ARM_CPU_HZ + TINY_ARM_BAUD / 2u) / TINY_ARM_BAUD);
  SYSCTL_RCGC1 |= 1u; /* UART0 */
  SYSCTL_RCGC2 |= 1u; /* GPIO A: PA0 = U0Rx, PA1 = U0Tx */
  GPIOA_AFSEL |= 3u;
  GPIOA_DEN |= 3u;
  UART0_CTL = 0;
  UART0_IBRD = div64 >> 6;
  UART0_FBRD = div64 & 63u;
  UART0_LCRH = 0x60u; /* 8 bits, no parity, 1 stop, no FIFOs */
  UART0_IM = 0x50u;   /* receive and receive-timeout interrupts */
  UART0_CTL = 0x301u; /* RXE, TXE, UARTEN */
  NVIC_ISER0 = 1u << UART0_IRQ;
  tiny_serial_rx_init(&decoder);
}

void tiny_port_report(const char *event, long value) {
  (void)event;
  arm_last_report = value;
}

long tiny_port_sensor(uint8_t channel) {
  switch (channel) {
    case TINY_SENSOR_LIGHT:
      return TINY_ARM_LIGHT;
    case TINY_SENSOR_WEIGHT:
      return TINY_ARM_WEIGHT;
    default:
      return 0;
  }
}

#ifdef TINY_ARM_RUN_MS
/* ARM semihosting: SYS_EXIT (0x18) with ADP_Stopped_ApplicationExit. */
static void semihosting_exit(void) {
  register uint32_t op __asm__("r0") = 0x18u;
  register uint32_t reason __asm__("r1") = 0x20026u;
  __asm__ volatile("bkpt 0xAB" : : "r"(op), "r"(reason) : "memory");
}
#endif

int main(void) {
  tiny_hal hal;
  uint16_t id = tiny_port_node_id();
  SYST_RVR = TINY_ARM_CPU_HZ / 1000u - 1u;
  SYST_CVR = 0;
  SYST_CSR = 7u; /* core clock, interrupt, enable */
  uart_init();
  hal = tiny_serial_hal(&uart, now_ms);
  tiny_init(&kernel, id, &hal);
  app_setup(&kernel);
  for (;;) {
    uint32_t now = now_ms(0);
    tiny_poll(&kernel, now);
    app_loop(&kernel, now);
#ifdef TINY_ARM_RUN_MS
    if (now >= (uint32_t)(TINY_ARM_RUN_MS)) semihosting_exit();
#endif
  }
}

/* ---- startup ------------------------------------------------------------ */
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;

void reset_handler(void) {
  uint32_t *src = &_sidata, *dst = &_sdata;
  while (dst < &_edata) *dst++ = *src++;
  for (dst = &_sbss; dst < &_ebss;) *dst++ = 0;
  (void)main();
  for (;;) {
  }
}

static void default_handler(void) {
  for (;;) {
  }
}

typedef void (*vector)(void);
/* Cortex-M3 core vectors, then the LM3S6965's IRQs up to UART0 (IRQ 5). */
__attribute__((section(".vectors"), used)) static const vector vectors[16 + UART0_IRQ + 1] = {
    (vector)(uintptr_t)&_estack,
    reset_handler,
    default_handler, /* NMI */
    default_handler, /* HardFault */
    default_handler, /* MemManage */
    default_handler, /* BusFault */
    default_handler, /* UsageFault */
    0,
    0,
    0,
    0,
    default_handler, /* SVCall */
    default_handler, /* DebugMon */
    0,
    default_handler, /* PendSV */
    systick_handler,
    default_handler, /* GPIO A */
    default_handler, /* GPIO B */
    default_handler, /* GPIO C */
    default_handler, /* GPIO D */
    default_handler, /* GPIO E */
    uart0_handler,   /* UART0 */
};
