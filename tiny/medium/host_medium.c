/* The simulated radio medium: see host_medium.h. */
#define _POSIX_C_SOURCE 200809L
#include "host_medium.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

uint32_t host_now_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint32_t)((uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u);
}

static unsigned env_unsigned(const char *name, unsigned fallback) {
  const char *v = getenv(name);
  char *end;
  unsigned long x;
  if (v == NULL || *v == '\0') return fallback;
  x = strtoul(v, &end, 10);
  return *end == '\0' ? (unsigned)x : fallback;
}

void host_medium_config_from_env(host_medium_config *cfg) {
  cfg->base_port = env_unsigned("TINY_MEDIUM_PORT", 47100);
  cfg->slots = env_unsigned("TINY_MEDIUM_SLOTS", 8);
  cfg->loss_pct = env_unsigned("TINY_LOSS", 0);
  cfg->dup_pct = env_unsigned("TINY_DUP", 0);
  cfg->delay_ms = env_unsigned("TINY_DELAY_MS", 0);
  cfg->jitter_ms = env_unsigned("TINY_JITTER_MS", 0);
  cfg->cut_file[0] = '\0';
  if (getenv("TINY_RADIO_CUT_FILE") != NULL &&
      strlen(getenv("TINY_RADIO_CUT_FILE")) < sizeof cfg->cut_file)
    strcpy(cfg->cut_file, getenv("TINY_RADIO_CUT_FILE"));
}

int host_medium_is_cut(host_medium *m) {
  struct stat st;
  uint32_t now;
  if (m->cfg.cut_file[0] == '\0') return 0;
  now = host_now_ms();
  if (!m->cut_checked || (uint32_t)(now - m->cut_checked_ms) >= HOST_MEDIUM_CUT_CHECK_MS) {
    m->is_cut = stat(m->cfg.cut_file, &st) == 0;
    m->cut_checked = 1;
    m->cut_checked_ms = now;
  }
  return m->is_cut;
}

static uint32_t rnd(host_medium *m) { /* xorshift32 */
  uint32_t x = m->rng;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  return m->rng = x;
}

static struct sockaddr_in addr_of(unsigned port) {
  struct sockaddr_in a;
  memset(&a, 0, sizeof a);
  a.sin_family = AF_INET;
  a.sin_port = htons((uint16_t)port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}

int host_medium_open(host_medium *m, const host_medium_config *cfg) {
  unsigned i;
  memset(m, 0, sizeof *m);
  m->cfg = *cfg;
  if (m->cfg.slots == 0 || m->cfg.slots > 64 || m->cfg.base_port == 0 ||
      m->cfg.base_port + m->cfg.slots > 65535u) {
    errno = EINVAL;
    return -1;
  }
  if (m->cfg.loss_pct > 100) m->cfg.loss_pct = 100;
  if (m->cfg.dup_pct > 100) m->cfg.dup_pct = 100;
  m->rng = (uint32_t)getpid() * 2654435761u ^ host_now_ms();
  if (m->rng == 0) m->rng = 1;
  m->fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (m->fd < 0) return -1;
  for (i = 0; i < m->cfg.slots; ++i) {
    struct sockaddr_in a = addr_of(m->cfg.base_port + i);
    if (bind(m->fd, (struct sockaddr *)&a, sizeof a) == 0) {
      m->slot = i;
      return fcntl(m->fd, F_SETFL, O_NONBLOCK) == 0 ? 0 : -1;
    }
  }
  close(m->fd);
  m->fd = -1;
  errno = EADDRINUSE;
  return -1;
}

void host_medium_close(host_medium *m) {
  if (m->fd >= 0) close(m->fd);
  m->fd = -1;
}

static void deliver(host_medium *m, unsigned port, const uint8_t *buf, uint8_t len) {
  struct sockaddr_in a = addr_of(port);
  /* Nobody on that port is fine: the radio does not know either. */
  (void)sendto(m->fd, buf, len, 0, (struct sockaddr *)&a, sizeof a);
}

static void enqueue(host_medium *m, unsigned port, const uint8_t *buf, uint8_t len) {
  unsigned i;
  uint32_t delay = m->cfg.delay_ms;
  if (m->cfg.jitter_ms > 0) delay += rnd(m) % (m->cfg.jitter_ms + 1u);
  if (delay == 0) {
    deliver(m, port, buf, len);
    return;
  }
  for (i = 0; i < HOST_MEDIUM_PENDING; ++i) {
    if (m->pending_used[i]) continue;
    m->pending_used[i] = 1;
    m->pending[i].due_ms = host_now_ms() + delay;
    m->pending[i].port = (uint16_t)port;
    m->pending[i].len = len;
    memcpy(m->pending[i].buf, buf, len);
    ++m->delayed;
    return;
  }
  ++m->overflow; /* a full queue loses the frame, as a busy radio would */
}

int host_medium_send(host_medium *m, const uint8_t *frame, uint8_t len) {
  unsigned i;
  if (len > TINY_FRAME_MAX) return -1;
  if (host_medium_is_cut(m)) {
    ++m->cut;
    return 0;
  }
  for (i = 0; i < m->cfg.slots; ++i) {
    unsigned port = m->cfg.base_port + i;
    if (i == m->slot) continue;
    if (rnd(m) % 100u < m->cfg.loss_pct) {
      ++m->lost;
      continue;
    }
    enqueue(m, port, frame, len);
    if (rnd(m) % 100u < m->cfg.dup_pct) {
      ++m->duplicated;
      enqueue(m, port, frame, len);
    }
  }
  return 0;
}

int host_medium_flush(host_medium *m, int idle_ms) {
  unsigned i;
  int next = idle_ms;
  uint32_t now = host_now_ms();
  for (i = 0; i < HOST_MEDIUM_PENDING; ++i) {
    int32_t left;
    if (!m->pending_used[i]) continue;
    left = (int32_t)(m->pending[i].due_ms - now);
    if (left <= 0) {
      deliver(m, m->pending[i].port, m->pending[i].buf, m->pending[i].len);
      m->pending_used[i] = 0;
    } else if (left < next) {
      next = (int)left;
    }
  }
  return next;
}

int host_medium_recv(host_medium *m, uint8_t *buf, uint8_t cap) {
  ssize_t n;
  (void)host_medium_flush(m, 0);
  /* MSG_TRUNC: the real size of a datagram longer than cap, so the kernel
   * counts it as too long instead of reading a cut frame. */
  n = recv(m->fd, buf, cap, MSG_TRUNC);
  if (n < 0) return 0;
  if (host_medium_is_cut(m)) {
    ++m->cut; /* heard nothing */
    return 0;
  }
  return n > 0x7FFF ? 0x7FFF : (int)n;
}
