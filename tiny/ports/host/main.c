/* main() of the host port: runs one device program (linked beside this
 * file) as a tiny node on the simulated medium.
 *
 *   <program> [--id N] [--run-ms N]
 *
 * Environment: TINY_MEDIUM_PORT, TINY_MEDIUM_SLOTS, TINY_LOSS, TINY_DUP,
 * TINY_DELAY_MS, TINY_JITTER_MS, TINY_RADIO_CUT_FILE (the medium, see host_medium.h);
 * TINY_LIGHT (the light sensor: a fixed level 0..1000, default a slow
 * day-night ramp), TINY_WEIGHT (the weight sensor in grams, default 1250),
 * TINY_SENSOR_FILE (a file of lines "light N" / "weight N" written by a
 * host-side adapter, e.g. peis-sim-sensors feeding the simulated home's
 * light model and objects; a channel it names wins over TINY_LIGHT and
 * TINY_WEIGHT, re-read at most every 100 ms).
 * A secured radio (docs/security.md): TINY_KEY (32 hex digits) is this
 * node's key; TINY_TRUST ("ID:KEY[:w] ...", separated by spaces or commas)
 * the senders whose frames it takes, ":w" those whose writes it applies (the
 * bridge); TINY_COUNTER_FILE keeps the frame counter across restarts
 * (default /tmp/tiny-counter-<id>).
 * Every report is a line "<event> <value>" on stdout; the kernel counters go
 * to stderr at exit (SIGINT, SIGTERM or --run-ms). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "host_medium.h"
#include "tiny_app.h"
#include "tiny_kernel.h"

static volatile sig_atomic_t stop_requested;
static uint32_t start_ms;

static void on_signal(int sig) {
  (void)sig;
  stop_requested = 1;
}

void tiny_port_report(const char *event, long value) {
  printf("%s %ld\n", event, value);
  fflush(stdout);
}

/* The sensor file: "light N" and "weight N" lines; -1 = not given. */
static long file_values[2] = {-1, -1};
static uint32_t file_read_ms;
static int file_read_once;

static void read_sensor_file(void) {
  const char *path = getenv("TINY_SENSOR_FILE");
  char name[16];
  long value;
  FILE *f;
  if (path == NULL || *path == '\0') return;
  if (file_read_once && (uint32_t)(host_now_ms() - file_read_ms) < 100u) return;
  file_read_once = 1;
  file_read_ms = host_now_ms();
  f = fopen(path, "r");
  if (f == NULL) return; /* not written yet: keep the last values */
  while (fscanf(f, "%15s %ld", name, &value) == 2) {
    if (strcmp(name, "light") == 0) file_values[TINY_SENSOR_LIGHT] = value;
    if (strcmp(name, "weight") == 0) file_values[TINY_SENSOR_WEIGHT] = value;
  }
  fclose(f);
}

long tiny_port_sensor(uint8_t channel) {
  const char *v;
  uint32_t t = host_now_ms() - start_ms;
  read_sensor_file();
  if (channel < 2 && file_values[channel] >= 0) return file_values[channel];
  switch (channel) {
    case TINY_SENSOR_LIGHT:
      v = getenv("TINY_LIGHT");
      if (v != NULL && *v != '\0') return strtol(v, NULL, 10);
      /* A day in 40 s: a triangle wave 0..1000. */
      t %= 40000u;
      return t < 20000u ? (long)(t / 20u) : (long)((40000u - t) / 20u);
    case TINY_SENSOR_WEIGHT:
      v = getenv("TINY_WEIGHT");
      if (v != NULL && *v != '\0') return strtol(v, NULL, 10);
      return 1250;
    default:
      return 0;
  }
}

static void print_stats(const tiny_kernel *k, const host_medium *m) {
  const tiny_stats *s = tiny_get_stats(k);
  fprintf(stderr,
          "tiny %u: rx %lu ok %lu tx %lu send-errors %lu | dropped: truncated %lu bad-length %lu "
          "bad-version %lu unknown-type %lu too-many-subkeys %lu bad-key %lu data-too-long %lu "
          "bad-src %lu | accepted %lu stale %lu unwanted %lu not-for-me %lu cache-full %lu "
          "subscribers-full %lu | secured: unsecured %lu unknown-sender %lu bad-mac %lu "
          "replay %lu forged-owner %lu | medium: lost %lu duplicated %lu delayed %lu "
          "overflow %lu cut %lu\n",
          (unsigned)k->id, (unsigned long)s->frames_rx, (unsigned long)s->frames_ok,
          (unsigned long)s->frames_tx, (unsigned long)s->send_errors,
          (unsigned long)s->drop_truncated, (unsigned long)s->drop_bad_length,
          (unsigned long)s->drop_bad_version, (unsigned long)s->drop_unknown_type,
          (unsigned long)s->drop_too_many_subkeys, (unsigned long)s->drop_bad_key,
          (unsigned long)s->drop_data_too_long, (unsigned long)s->drop_bad_src,
          (unsigned long)s->tuples_accepted, (unsigned long)s->tuples_stale,
          (unsigned long)s->tuples_unwanted, (unsigned long)s->not_for_me,
          (unsigned long)s->cache_full, (unsigned long)s->subscribers_full,
          (unsigned long)s->drop_unsecured, (unsigned long)s->drop_unknown_sender,
          (unsigned long)s->drop_bad_mac, (unsigned long)s->drop_replay,
          (unsigned long)s->drop_forged_owner, (unsigned long)m->lost, (unsigned long)m->duplicated,
          (unsigned long)m->delayed, (unsigned long)m->overflow, (unsigned long)m->cut);
}

static int parse_arg(const char *v, unsigned long max, unsigned long *out) {
  char *end;
  unsigned long x;
  if (v == NULL || *v == '\0') return -1;
  errno = 0;
  x = strtoul(v, &end, 10);
  if (errno != 0 || *end != '\0' || x > max) return -1;
  *out = x;
  return 0;
}

static host_medium medium;
static tiny_kernel kernel;
static char counter_file[256];

/* The frame counter of a secured radio, in a file (written whole, then
 * renamed: a crash leaves the old value or the new one). */
static int hal_load_counter(void *ctx, uint32_t *value) {
  FILE *f = fopen(counter_file, "r");
  unsigned long v = 0;
  (void)ctx;
  *value = 0;
  if (f == NULL) return errno == ENOENT ? 0 : -1;
  if (fscanf(f, "%lu", &v) == 1) *value = (uint32_t)v;
  fclose(f);
  return 0;
}
static int hal_store_counter(void *ctx, uint32_t value) {
  char temp[300];
  FILE *f;
  (void)ctx;
  snprintf(temp, sizeof temp, "%s.new", counter_file);
  f = fopen(temp, "w");
  if (f == NULL) return -1;
  fprintf(f, "%lu\n", (unsigned long)value);
  if (fclose(f) != 0) return -1;
  return rename(temp, counter_file);
}

static int parse_key(const char *hex, size_t n, uint8_t key[TINY_MAC_KEY_SIZE]) {
  size_t i;
  if (n != 2 * TINY_MAC_KEY_SIZE) return -1;
  for (i = 0; i < TINY_MAC_KEY_SIZE; ++i) {
    unsigned v;
    if (sscanf(hex + 2 * i, "%2x", &v) != 1) return -1;
    key[i] = (uint8_t)v;
  }
  return 0;
}

/* TINY_KEY and TINY_TRUST: 0, or -1 with the reason printed. */
static int secure_from_env(const char *program, unsigned long id) {
  const char *key_text = getenv("TINY_KEY"), *trust = getenv("TINY_TRUST");
  const char *file = getenv("TINY_COUNTER_FILE");
  uint8_t key[TINY_MAC_KEY_SIZE];
  if (key_text == NULL || *key_text == '\0') return 0;
  if (file != NULL && *file != '\0') {
    snprintf(counter_file, sizeof counter_file, "%s", file);
  } else {
    snprintf(counter_file, sizeof counter_file, "/tmp/tiny-counter-%lu", id);
  }
  if (parse_key(key_text, strlen(key_text), key) != 0) {
    fprintf(stderr, "%s: TINY_KEY must be 32 hex digits\n", program);
    return -1;
  }
  if (tiny_secure(&kernel, key) != TINY_OK) {
    fprintf(stderr, "%s: cannot keep the frame counter in %s\n", program, counter_file);
    return -1;
  }
  while (trust != NULL && *trust != '\0') {
    unsigned long node;
    char *end;
    const char *hex;
    size_t n;
    uint8_t may_write = 0;
    while (*trust == ' ' || *trust == ',') ++trust;
    if (*trust == '\0') break;
    node = strtoul(trust, &end, 10);
    if (end == trust || *end != ':' || node == 0 || node > 0xFFFEul) {
      fprintf(stderr, "%s: TINY_TRUST: expected ID:KEY[:w] at '%s'\n", program, trust);
      return -1;
    }
    hex = end + 1;
    n = strcspn(hex, ":, ");
    if (parse_key(hex, n, key) != 0) {
      fprintf(stderr, "%s: TINY_TRUST: the key of %lu must be 32 hex digits\n", program, node);
      return -1;
    }
    trust = hex + n;
    if (*trust == ':') {
      may_write = trust[1] == 'w';
      trust += 2;
    }
    if (tiny_trust(&kernel, (uint16_t)node, key, may_write) != TINY_OK) {
      fprintf(stderr, "%s: TINY_TRUST: more than %d senders\n", program, TINY_MAX_KEYS);
      return -1;
    }
  }
  fprintf(stderr, "tiny %lu: secured radio (counter in %s)\n", id, counter_file);
  return 0;
}

/* The tiny kernel's HAL on the simulated medium (ctx = the medium). */
static int hal_send(void *ctx, const uint8_t *frame, uint8_t len) {
  return host_medium_send((host_medium *)ctx, frame, len);
}
static int hal_recv(void *ctx, uint8_t *buf, uint8_t cap) {
  return host_medium_recv((host_medium *)ctx, buf, cap);
}
static uint32_t hal_now(void *ctx) {
  (void)ctx;
  return host_now_ms();
}

int main(int argc, char **argv) {
  host_medium_config cfg;
  tiny_hal hal;
  unsigned long id = app_default_id(), run_ms = 0;
  int i;
  struct sigaction sa;
  for (i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--id") == 0 && i + 1 < argc) {
      if (parse_arg(argv[++i], 0xFFFEul, &id) != 0 || id == 0) {
        fprintf(stderr, "%s: --id takes 1..65534\n", argv[0]);
        return 2;
      }
    } else if (strcmp(argv[i], "--run-ms") == 0 && i + 1 < argc) {
      if (parse_arg(argv[++i], 0xFFFFFFFFul, &run_ms) != 0) {
        fprintf(stderr, "%s: --run-ms takes milliseconds\n", argv[0]);
        return 2;
      }
    } else {
      fprintf(stderr, "usage: %s [--id N] [--run-ms N]\n", argv[0]);
      return 2;
    }
  }
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);

  host_medium_config_from_env(&cfg);
  if (host_medium_open(&medium, &cfg) != 0) {
    fprintf(stderr, "%s: cannot join the medium on 127.0.0.1:%u..%u: %s\n", argv[0], cfg.base_port,
            cfg.base_port + cfg.slots - 1, strerror(errno));
    return 1;
  }
  memset(&hal, 0, sizeof hal);
  hal.ctx = &medium;
  hal.send = hal_send;
  hal.load_counter = hal_load_counter;
  hal.store_counter = hal_store_counter;
  hal.recv = hal_recv;
  hal.now_ms = hal_now;
  start_ms = host_now_ms();
  tiny_init(&kernel, (uint16_t)id, &hal);
  fprintf(stderr, "tiny %lu on 127.0.0.1:%u\n", id, cfg.base_port + medium.slot);
  if (secure_from_env(argv[0], id) != 0) return 2;
  app_setup(&kernel);
  while (!stop_requested) {
    struct pollfd pfd;
    uint32_t now = host_now_ms();
    int wait_ms;
    if (run_ms != 0 && (uint32_t)(now - start_ms) >= run_ms) break;
    tiny_poll(&kernel, now);
    app_loop(&kernel, now);
    wait_ms = host_medium_flush(&medium, 10);
    pfd.fd = medium.fd;
    pfd.events = POLLIN;
    pfd.revents = 0;
    (void)poll(&pfd, 1, wait_ms);
  }
  print_stats(&kernel, &medium);
  host_medium_close(&medium);
  return 0;
}
