/* tiny_serial_probe: plays a full PEIS (by default 6890, the lamp's source)
 * on the serial line of an emulated tiny node, to check that the firmware's
 * UART carries tiny frames in tiny_serial framing (0x7E LEN FRAME CHK) and
 * that the node behaves as a PEIS:
 *
 *   1. connect to the emulator's UART socket (UNIX stream; retried until the
 *      deadline, as the emulator may still be starting);
 *   2. wait for the node's BEACON and its SUBSCRIBE to (source, in-key);
 *   3. send a SUBSCRIBE to (node, out-key): a tiny node only sends its own
 *      tuples to its subscribers;
 *   4. send a TUPLE <source, [in-key], value> addressed to the node;
 *   5. wait for the node's own TUPLE <node, [out-key], value>.
 * Steps 3 and 4 are repeated every second (new seqno each time) until the
 * answer arrives, so a frame lost at start-up does not fail the test.
 *
 * Exit status 0 when the answer arrived before the deadline; 1 with a
 * message naming the step that did not happen otherwise; 2 on bad usage.
 *
 *   tiny_serial_probe --socket PATH [--node 7] [--source 6890] [--in-key 42]
 *                     [--out-key 45] [--value 100] [--deadline-ms 30000]
 * Defaults are the lamp's; the blind is --node 4 --source 3 --in-key 43
 * --out-key 46.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "tiny_serial.h"
#include "tiny_tuple.h"

typedef struct options {
  const char *socket_path;
  unsigned node, source, in_key, out_key;
  const char *value;
  long deadline_ms;
} options;

static long long start_ms;

static long long mono_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

static void say(const char *fmt, ...) {
  va_list ap;
  fprintf(stderr, "probe [%6lld ms] ", mono_ms() - start_ms);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
}

static int usage(const char *msg) {
  fprintf(stderr,
          "error: %s\nusage: tiny_serial_probe --socket PATH [--node N] [--source N] "
          "[--in-key K] [--out-key K] [--value TEXT] [--deadline-ms MS]\n",
          msg);
  return 2;
}

static int parse_uint(const char *s, unsigned max, unsigned *out) {
  char *end;
  unsigned long v;
  errno = 0;
  v = strtoul(s, &end, 10);
  if (errno != 0 || *s == '\0' || *end != '\0' || v > max) return -1;
  *out = (unsigned)v;
  return 0;
}

static int parse_args(int argc, char **argv, options *o) {
  int i;
  o->socket_path = NULL;
  o->node = 7;
  o->source = 6890;
  o->in_key = 42;
  o->out_key = 45;
  o->value = "100";
  o->deadline_ms = 30000;
  for (i = 1; i < argc; ++i) {
    const char *a = argv[i];
    const char *v = i + 1 < argc ? argv[i + 1] : NULL;
    unsigned u;
    if (v == NULL) return usage("every option takes a value");
    if (strcmp(a, "--socket") == 0) {
      o->socket_path = v;
    } else if (strcmp(a, "--value") == 0) {
      if (strlen(v) > 20) return usage("--value is at most 20 bytes");
      o->value = v;
    } else if (strcmp(a, "--deadline-ms") == 0) {
      if (parse_uint(v, 3600000u, &u) != 0 || u == 0) return usage("--deadline-ms is 1..3600000");
      o->deadline_ms = (long)u;
    } else if (parse_uint(v, 0xFFFEu, &u) != 0 || u == 0) {
      return usage("option values are integers 1..65534");
    } else if (strcmp(a, "--node") == 0) {
      o->node = u;
    } else if (strcmp(a, "--source") == 0) {
      o->source = u;
    } else if (strcmp(a, "--in-key") == 0) {
      o->in_key = u;
    } else if (strcmp(a, "--out-key") == 0) {
      o->out_key = u;
    } else {
      return usage("unknown option");
    }
    ++i;
  }
  if (o->socket_path == NULL) return usage("--socket PATH is required");
  return 0;
}

/* Connects to the UNIX socket. run_emulated.sh starts the client only once
 * the emulator's listening socket exists, so one attempt is enough. */
static int connect_socket(const char *path) {
  struct sockaddr_un addr;
  int fd;
  if (strlen(path) >= sizeof addr.sun_path) {
    say("FAIL: socket path too long: %s", path);
    return -1;
  }
  memset(&addr, 0, sizeof addr);
  addr.sun_family = AF_UNIX;
  strcpy(addr.sun_path, path);
  fd = socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0) {
    say("FAIL: socket(): %s", strerror(errno));
    return -1;
  }
  if (connect(fd, (const struct sockaddr *)&addr, sizeof addr) != 0) {
    say("FAIL: could not connect to %s: %s", path, strerror(errno));
    close(fd);
    return -1;
  }
  return fd;
}

static int write_all(int fd, const uint8_t *p, size_t n) {
  while (n > 0) {
    ssize_t w = write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return -1;
    }
    p += w;
    n -= (size_t)w;
  }
  return 0;
}

/* Sends one radio frame in serial framing. */
static int send_frame(int fd, const uint8_t *frame, size_t len) {
  uint8_t wire[TINY_SERIAL_MAX];
  uint8_t n = tiny_serial_encode(wire, frame, (uint8_t)len);
  if (n == 0 || write_all(fd, wire, n) != 0) {
    say("FAIL: cannot write to the emulator's UART: %s", strerror(errno));
    return -1;
  }
  return 0;
}

static const char *type_name(uint8_t type) {
  switch (type) {
    case TINY_FRAME_TUPLE:
      return "TUPLE";
    case TINY_FRAME_SUBSCRIBE:
      return "SUBSCRIBE";
    case TINY_FRAME_UNSUBSCRIBE:
      return "UNSUBSCRIBE";
    case TINY_FRAME_BEACON:
      return "BEACON";
    case TINY_FRAME_WRITE:
      return "WRITE";
    default:
      return "?";
  }
}

int main(int argc, char **argv) {
  options o;
  int fd, rc;
  long long deadline, next_send = 0;
  int seen_beacon = 0, seen_sub = 0, sent = 0;
  uint16_t seq = 0;
  uint32_t seqno = 0;
  unsigned frames = 0;
  tiny_serial_rx rx;
  tiny_stats stats;

  start_ms = mono_ms();
  if ((rc = parse_args(argc, argv, &o)) != 0) return rc;
  deadline = start_ms + o.deadline_ms;
  memset(&stats, 0, sizeof stats);
  tiny_serial_rx_init(&rx);
  say("node %u, source %u: expecting SUBSCRIBE to <%u, [%u]>, answer <%u, [%u], \"%s\">", o.node,
      o.source, o.source, o.in_key, o.node, o.out_key, o.value);

  fd = connect_socket(o.socket_path);
  if (fd < 0) return 1;
  say("connected to %s", o.socket_path);

  for (;;) {
    long long now = mono_ms();
    struct pollfd pfd;
    uint8_t bytes[256];
    ssize_t n, i;
    if (now >= deadline) {
      say("FAIL: deadline of %ld ms passed: %u frames from the node; beacon %s, subscribe %s, "
          "tuple %s, answer not seen (serial decoder: %lu bad length, %lu bad checksum)",
          o.deadline_ms, frames, seen_beacon ? "seen" : "NOT seen", seen_sub ? "seen" : "NOT seen",
          sent ? "sent" : "NOT sent", (unsigned long)rx.bad_length, (unsigned long)rx.bad_checksum);
      close(fd);
      return 1;
    }
    if (seen_beacon && seen_sub && now >= next_send) {
      uint8_t frame[TINY_FRAME_MAX];
      tiny_key out_key = tiny_key1((uint16_t)o.out_key);
      tiny_key in_key = tiny_key1((uint16_t)o.in_key);
      tiny_tuple t;
      size_t len;
      len = tiny_encode_sub_frame(frame, TINY_FRAME_SUBSCRIBE, (uint16_t)o.source, (uint16_t)o.node,
                                  seq++, (uint16_t)o.node, 0, &out_key);
      if (len == 0 || send_frame(fd, frame, len) != 0) return 1;
      memset(&t, 0, sizeof t);
      t.owner = (uint16_t)o.source;
      t.creator = (uint16_t)o.source;
      t.seqno = ++seqno;
      t.ts_write = (uint32_t)(now - start_ms);
      if (tiny_tuple_set_key_data(&t, &in_key, o.value, (uint8_t)strlen(o.value)) != 0) {
        say("FAIL: cannot build the tuple");
        return 1;
      }
      len = tiny_encode_tuple_frame(frame, (uint16_t)o.source, (uint16_t)o.node, seq++, &t);
      if (len == 0 || send_frame(fd, frame, len) != 0) return 1;
      say("sent SUBSCRIBE <%u, [%u]> and TUPLE <%u, [%u], \"%s\"> seqno %lu to node %u", o.node,
          o.out_key, o.source, o.in_key, o.value, (unsigned long)seqno, o.node);
      sent = 1;
      next_send = now + 1000;
    }
    pfd.fd = fd;
    pfd.events = POLLIN;
    pfd.revents = 0;
    rc = poll(&pfd, 1, 50);
    if (rc < 0 && errno != EINTR) {
      say("FAIL: poll(): %s", strerror(errno));
      return 1;
    }
    if (rc <= 0) continue;
    n = read(fd, bytes, sizeof bytes);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      say("FAIL: the emulator closed the UART (%s)", n < 0 ? strerror(errno) : "end of file");
      return 1;
    }
    for (i = 0; i < n; ++i) {
      tiny_frame f;
      uint8_t len = tiny_serial_rx_byte(&rx, bytes[i]);
      if (len == 0) continue;
      if (tiny_decode_frame(rx.buf, len, &f, &stats) != TINY_DECODE_OK) {
        say("a framed but undecodable frame of %u bytes", (unsigned)len);
        continue;
      }
      if (f.src != o.node) {
        say("%s from node %u (not the node under test), ignored", type_name(f.type),
            (unsigned)f.src);
        continue;
      }
      ++frames;
      switch (f.type) {
        case TINY_FRAME_BEACON:
          if (!seen_beacon)
            say("BEACON from %u: flags %u, %u tuples, uptime %lu ms", (unsigned)f.src,
                (unsigned)f.beacon_flags, (unsigned)f.beacon_tuples,
                (unsigned long)f.beacon_uptime_ms);
          seen_beacon = 1;
          break;
        case TINY_FRAME_SUBSCRIBE:
          if (f.sub_owner == o.source && f.sub_key.len == 1 && f.sub_key.sub[0] == o.in_key &&
              f.sub_flags == 0) {
            if (!seen_sub) say("SUBSCRIBE from %u to <%u, [%u]>", o.node, o.source, o.in_key);
            seen_sub = 1;
          } else {
            say("SUBSCRIBE from %u to owner %u (%u sub-keys), not the expected one", o.node,
                (unsigned)f.sub_owner, (unsigned)f.sub_key.len);
          }
          break;
        case TINY_FRAME_TUPLE: {
          const tiny_tuple *t = &f.tuple;
          size_t vlen = strlen(o.value);
          int match = t->owner == o.node && t->key_len == 1 &&
                      tiny_tuple_subkey(t, 0) == o.out_key && t->data_len == vlen &&
                      memcmp(tiny_tuple_data(t), o.value, vlen) == 0;
          say("TUPLE from %u (dst %u): <%u, [%u], \"%.*s\"> seqno %lu%s", (unsigned)f.src,
              (unsigned)f.dst, (unsigned)t->owner, (unsigned)tiny_tuple_subkey(t, 0),
              (int)t->data_len, (const char *)tiny_tuple_data(t), (unsigned long)t->seqno,
              match ? "" : " (not the expected answer)");
          if (match) {
            say("PASS: node %u published <%u, [%u], \"%s\"> after the tuple from %u", o.node,
                o.node, o.out_key, o.value, o.source);
            close(fd);
            return 0;
          }
          break;
        }
        default:
          say("%s from %u", type_name(f.type), (unsigned)f.src);
          break;
      }
    }
  }
}
