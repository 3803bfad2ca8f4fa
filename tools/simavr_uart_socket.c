/* simavr_uart_socket: runs an AVR firmware ELF under simavr and bridges one
 * of its USARTs (USART0 by default) to a UNIX stream socket, byte for byte.
 *
 * LICENCE NOTE. This program links libsimavr, which is licensed under the
 * GNU General Public License version 3 (or later). It is therefore a
 * SEPARATE TEST TOOL, distributed under the terms of the GNU GPL version 3
 * or (at your option) any later version (SPDX: GPL-3.0-or-later). It is
 * built only for the emulated tests (tests/emulated/), is never linked into
 * any PEIS library, program or firmware, and talks to the rest of the
 * project only through a socket. Do not move code from this file into the
 * project's libraries.
 *
 * Usage:
 *   simavr_uart_socket --socket PATH [--mcu atmega128] [--freq 16000000]
 *                      [--uart 0] [--time-limit SECONDS] [--fast] [-v]
 *                      [--eeprom FILE] FIRMWARE.elf
 *
 *  - The MCU and its clock come from the ELF's .mmcu section
 *    (avr_mcu_section.h) when it has one; --mcu and --freq override or
 *    supply them (the project's firmware has no .mmcu section, so the
 *    tests pass both).
 *  - The socket is a server for one client at a time; a second connection
 *    is refused (accepted and closed at once) while one is open. Bytes the
 *    firmware sends while no client is connected are dropped (as with
 *    qemu's `-serial unix:PATH,server=on,wait=off`). Bytes from the client
 *    are queued and handed to the USART with simavr's XON/XOFF flow
 *    control, so none are lost to the USART's 64-byte input FIFO; the
 *    USART itself delivers them to the firmware at the programmed baud rate.
 *  - The simulation is paced to real time (the AVR's cycle count against
 *    the wall clock), so the firmware's millisecond clock runs at the
 *    speed of the host's; --fast runs as fast as the host can instead.
 *  - --eeprom FILE: the EEPROM's contents from its first byte (the rest
 *    stays erased, 0xFF), e.g. a secured radio's keys.
 *  - --time-limit (wall-clock seconds, default 60) ends the run with exit
 *    status 0; SIGTERM and SIGINT too. The firmware stopping (sleep with
 *    interrupts off, or a crash) ends it with status 1. Bad usage: 2.
 */
#define _POSIX_C_SOURCE 200809L

#include <avr_eeprom.h>
#include <avr_uart.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_io.h>
#include <sim_irq.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define IN_CAP 4096u  /* client -> firmware queue */
#define OUT_CAP 4096u /* firmware -> client buffer, flushed every slice */

static struct {
  avr_t *avr;
  avr_irq_t *uart_in;
  int listen_fd;
  int client_fd;
  uint8_t in[IN_CAP];
  size_t in_head, in_len;
  int xoff;
  uint8_t out[OUT_CAP];
  size_t out_len;
  unsigned long long to_avr, from_avr, dropped;
  int verbose;
} g;

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig) { stop_signal = sig; }

static double mono_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void note(const char *fmt, ...) {
  va_list ap;
  fputs("simavr_uart_socket: ", stderr);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
}

static int usage(const char *msg) {
  note("error: %s", msg);
  fputs(
      "usage: simavr_uart_socket --socket PATH [--mcu NAME] [--freq HZ] [--uart N]\n"
      "                          [--time-limit SECONDS] [--fast] [-v] [--eeprom FILE]\n"
      "                          FIRMWARE.elf\n",
      stderr);
  return 2;
}

/* ---- USART <-> queues (called from inside the simulation) -------------- */

static void feed_uart(void) {
  while (!g.xoff && g.in_len > 0) {
    uint8_t b = g.in[g.in_head];
    g.in_head = (g.in_head + 1) % IN_CAP;
    --g.in_len;
    ++g.to_avr;
    avr_raise_irq(g.uart_in, b); /* may call xoff_hook before returning */
  }
}

static void output_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)param;
  ++g.from_avr;
  if (g.client_fd < 0 || g.out_len >= OUT_CAP) {
    ++g.dropped;
    return;
  }
  g.out[g.out_len++] = (uint8_t)value;
}

static void xon_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  (void)param;
  g.xoff = 0;
  feed_uart();
}

static void xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  (void)param;
  g.xoff = 1;
}

/* ---- the socket -------------------------------------------------------- */

static int make_server(const char *path) {
  struct sockaddr_un addr;
  int fd;
  if (strlen(path) >= sizeof addr.sun_path) {
    note("error: socket path too long: %s", path);
    return -1;
  }
  memset(&addr, 0, sizeof addr);
  addr.sun_family = AF_UNIX;
  strcpy(addr.sun_path, path);
  fd = socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0) {
    note("error: socket(): %s", strerror(errno));
    return -1;
  }
  (void)unlink(path); /* a stale socket from an earlier run */
  if (bind(fd, (const struct sockaddr *)&addr, sizeof addr) != 0 || listen(fd, 1) != 0) {
    note("error: cannot listen on %s: %s", path, strerror(errno));
    close(fd);
    return -1;
  }
  (void)fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
  return fd;
}

static void drop_client(const char *why) {
  if (g.client_fd < 0) return;
  note("client disconnected (%s)", why);
  close(g.client_fd);
  g.client_fd = -1;
  g.out_len = 0;
}

static void flush_out(void) {
  size_t off = 0;
  while (g.client_fd >= 0 && off < g.out_len) {
    ssize_t w = send(g.client_fd, g.out + off, g.out_len - off, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (w < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) { /* a slow client: drop the rest */
        g.dropped += g.out_len - off;
        break;
      }
      drop_client(strerror(errno));
      break;
    }
    off += (size_t)w;
  }
  g.out_len = 0;
}

/* Waits up to timeout_ms for a connection or client bytes and takes them. */
static void service_socket(int timeout_ms) {
  struct pollfd p[2];
  int n = 0, rc;
  p[n].fd = g.listen_fd;
  p[n].events = POLLIN;
  p[n++].revents = 0;
  if (g.client_fd >= 0 && g.in_len < IN_CAP) {
    p[n].fd = g.client_fd;
    p[n].events = POLLIN;
    p[n++].revents = 0;
  }
  rc = poll(p, (nfds_t)n, timeout_ms);
  if (rc <= 0) return;
  if (p[0].revents & POLLIN) {
    int fd = accept(g.listen_fd, NULL, NULL);
    if (fd >= 0) {
      if (g.client_fd >= 0) {
        note("refused a second client (one at a time)");
        close(fd);
      } else {
        g.client_fd = fd;
        note("client connected");
      }
    }
  }
  if (n > 1 && (p[1].revents & (POLLIN | POLLHUP | POLLERR))) {
    uint8_t buf[512];
    size_t room = IN_CAP - g.in_len;
    ssize_t r = read(g.client_fd, buf, room < sizeof buf ? room : sizeof buf);
    if (r == 0) {
      drop_client("end of file");
    } else if (r < 0) {
      if (errno != EINTR && errno != EAGAIN) drop_client(strerror(errno));
    } else {
      ssize_t i;
      for (i = 0; i < r; ++i) g.in[(g.in_head + g.in_len + (size_t)i) % IN_CAP] = buf[i];
      g.in_len += (size_t)r;
      feed_uart();
    }
  }
}

/* ---- the EEPROM ------------------------------------------------------------ */

static int load_eeprom(const char *path) {
  static uint8_t bytes[4096];
  avr_eeprom_desc_t desc;
  size_t n;
  FILE *f = fopen(path, "rb");
  if (f == NULL) {
    note("error: cannot open the EEPROM image %s: %s", path, strerror(errno));
    return 1;
  }
  n = fread(bytes, 1, sizeof bytes, f);
  fclose(f);
  /* simavr's EEPROM ioctls answer -1 even when they worked: read back. */
  desc.ee = bytes;
  desc.offset = 0;
  desc.size = (uint32_t)n;
  if (n > 0) avr_ioctl(g.avr, AVR_IOCTL_EEPROM_SET, &desc);
  desc.ee = NULL;
  avr_ioctl(g.avr, AVR_IOCTL_EEPROM_GET, &desc);
  if (n == 0 || desc.ee == NULL || memcmp(desc.ee, bytes, n) != 0) {
    note("error: cannot load %s into the EEPROM", path);
    return 1;
  }
  return 0;
}

/* ---- main -------------------------------------------------------------- */

int main(int argc, char **argv) {
  const char *socket_path = NULL, *elf = NULL, *mcu = NULL, *eeprom = NULL;
  unsigned long freq = 0;
  char uart = '0';
  double time_limit = 60.0, start, wall;
  int fast = 0, i, status = 0;
  elf_firmware_t fw;
  uint32_t flags = 0;
  avr_cycle_count_t slice;
  struct sigaction sa;

  for (i = 1; i < argc; ++i) {
    const char *a = argv[i];
    const char *v = i + 1 < argc ? argv[i + 1] : NULL;
    if (strcmp(a, "--fast") == 0) {
      fast = 1;
    } else if (strcmp(a, "-v") == 0) {
      g.verbose = 1;
    } else if (a[0] == '-' && v == NULL) {
      return usage("an option lacks its value");
    } else if (strcmp(a, "--socket") == 0) {
      socket_path = argv[++i];
    } else if (strcmp(a, "--eeprom") == 0) {
      eeprom = argv[++i];
    } else if (strcmp(a, "--mcu") == 0) {
      mcu = argv[++i];
    } else if (strcmp(a, "--freq") == 0) {
      freq = strtoul(argv[++i], NULL, 10);
      if (freq == 0) return usage("--freq takes a frequency in Hz");
    } else if (strcmp(a, "--uart") == 0) {
      uart = argv[++i][0];
    } else if (strcmp(a, "--time-limit") == 0) {
      time_limit = strtod(argv[++i], NULL);
      if (!(time_limit > 0)) return usage("--time-limit takes seconds > 0");
    } else if (a[0] == '-') {
      return usage("unknown option");
    } else if (elf == NULL) {
      elf = a;
    } else {
      return usage("one firmware ELF only");
    }
  }
  if (socket_path == NULL || elf == NULL) return usage("--socket PATH and FIRMWARE.elf needed");

  memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf, &fw) != 0) {
    note("error: cannot read the firmware %s", elf);
    return 1;
  }
  if (mcu != NULL) snprintf(fw.mmcu, sizeof fw.mmcu, "%s", mcu);
  if (freq != 0) fw.frequency = (uint32_t)freq;
  if (fw.mmcu[0] == '\0' || fw.frequency == 0)
    return usage("the ELF has no .mmcu section: give --mcu and --freq");
  g.avr = avr_make_mcu_by_name(fw.mmcu);
  if (g.avr == NULL) {
    note("error: simavr knows no MCU named %s", fw.mmcu);
    return 1;
  }
  avr_init(g.avr);
  g.avr->log = g.verbose ? LOG_TRACE : LOG_WARNING;
  avr_load_firmware(g.avr, &fw);
  g.avr->frequency = fw.frequency;
  if (eeprom != NULL && load_eeprom(eeprom) != 0) return 1;

  /* No console echo of the USART, no sleeping on polled reception. */
  if (avr_ioctl(g.avr, AVR_IOCTL_UART_GET_FLAGS(uart), &flags) != 0) {
    note("error: %s has no USART%c", fw.mmcu, uart);
    return 1;
  }
  flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(g.avr, AVR_IOCTL_UART_SET_FLAGS(uart), &flags);
  g.uart_in = avr_io_getirq(g.avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_INPUT);
  avr_irq_register_notify(avr_io_getirq(g.avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_OUTPUT),
                          output_hook, NULL);
  avr_irq_register_notify(avr_io_getirq(g.avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_OUT_XON),
                          xon_hook, NULL);
  avr_irq_register_notify(avr_io_getirq(g.avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_OUT_XOFF),
                          xoff_hook, NULL);

  g.client_fd = -1;
  g.listen_fd = make_server(socket_path);
  if (g.listen_fd < 0) return 1;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGINT, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);
  note("%s at %lu Hz, USART%c on %s, %s, time limit %.0f s", fw.mmcu, (unsigned long)fw.frequency,
       uart, socket_path, fast ? "as fast as possible" : "real time", time_limit);

  slice = fw.frequency / 1000u; /* 1 ms of AVR time between socket checks */
  start = mono_s();
  for (;;) {
    avr_cycle_count_t until = g.avr->cycle + slice;
    int wait_ms = 0;
    while (g.avr->cycle < until) {
      int state = avr_run(g.avr);
      if (state == cpu_Done || state == cpu_Crashed) {
        note("the firmware stopped (%s) after %.3f s of AVR time",
             state == cpu_Done ? "done" : "crashed", (double)g.avr->cycle / fw.frequency);
        status = 1;
        goto out;
      }
    }
    flush_out();
    wall = mono_s() - start;
    if (stop_signal != 0) {
      note("stopped by signal %d", (int)stop_signal);
      goto out;
    }
    if (wall >= time_limit) {
      note("time limit of %.0f s reached", time_limit);
      goto out;
    }
    if (!fast) { /* ahead of the wall clock: wait (for the socket) the difference */
      double ahead = (double)g.avr->cycle / fw.frequency - wall;
      if (ahead > 0.001) wait_ms = (int)(ahead * 1000.0);
    }
    service_socket(wait_ms);
  }
out:
  note(
      "%.3f s of AVR time in %.3f s; %llu bytes to the firmware, %llu from it (%llu dropped: "
      "no client)",
      (double)g.avr->cycle / fw.frequency, mono_s() - start, g.to_avr, g.from_avr, g.dropped);
  if (g.client_fd >= 0) close(g.client_fd);
  close(g.listen_fd);
  (void)unlink(socket_path);
  avr_terminate(g.avr);
  return status;
}
