/* The simulated radio: an 802.15.4-like broadcast medium over UDP on
 * 127.0.0.1, joined by the host port's device programs, by the tinybridge
 * (as its base station) and by tests. It carries frames; it knows nothing of
 * the tiny kernel (the host port binds it to the kernel's HAL).
 *
 * The medium is a range of `slots` ports from `base_port`; each node binds
 * the first free one and sends every frame to all the others (so any number
 * of processes up to `slots` share one medium, and separate tests use
 * separate bases). Loss, duplication and delay (with jitter) are applied on
 * the sending side, per frame and per receiver.
 *
 * A member's link can be cut while it runs (a fault a scenario injects):
 * while the file TINY_RADIO_CUT_FILE names exists, the member sends nothing
 * and hears nothing, as a node whose antenna came off (checked at most
 * every HOST_MEDIUM_CUT_CHECK_MS; frames lost so are counted in `cut`).
 */
#ifndef TINY_HOST_MEDIUM_H
#define TINY_HOST_MEDIUM_H

#include <stdint.h>

#include "tiny_tuple.h" /* TINY_FRAME_MAX */

#ifdef __cplusplus
extern "C" {
#endif

#define HOST_MEDIUM_PENDING 64       /* delayed frames held at once */
#define HOST_MEDIUM_CUT_CHECK_MS 100 /* how often the cut file is looked at */
#define HOST_MEDIUM_PATH_MAX 256

typedef struct host_medium_config {
  unsigned base_port;                  /* TINY_MEDIUM_PORT, default 47100 */
  unsigned slots;                      /* TINY_MEDIUM_SLOTS, default 8 (max 64) */
  unsigned loss_pct;                   /* TINY_LOSS: percent of frames lost */
  unsigned dup_pct;                    /* TINY_DUP: percent of frames delivered twice */
  unsigned delay_ms;                   /* TINY_DELAY_MS: fixed delay of every frame */
  unsigned jitter_ms;                  /* TINY_JITTER_MS: extra random delay 0..jitter */
  char cut_file[HOST_MEDIUM_PATH_MAX]; /* TINY_RADIO_CUT_FILE: "" = never cut */
} host_medium_config;

typedef struct host_pending {
  uint32_t due_ms;
  uint16_t port;
  uint8_t len;
  uint8_t buf[TINY_FRAME_MAX];
} host_pending;

typedef struct host_medium {
  host_medium_config cfg;
  int fd;
  unsigned slot;
  uint32_t rng;
  uint32_t lost, duplicated, delayed, overflow, cut;
  int is_cut;              /* the cut file existed at the last check */
  uint32_t cut_checked_ms; /* when it was looked at */
  int cut_checked;
  host_pending pending[HOST_MEDIUM_PENDING];
  uint8_t pending_used[HOST_MEDIUM_PENDING];
} host_medium;

/* Fills cfg from the environment (defaults above). */
void host_medium_config_from_env(host_medium_config *cfg);
/* Opens the medium: binds the first free slot. Returns 0, or -1 (errno). */
int host_medium_open(host_medium *m, const host_medium_config *cfg);
void host_medium_close(host_medium *m);
/* Sends one frame (len <= TINY_FRAME_MAX) to every other slot, with the
 * configured loss, duplication and delay (nothing while the link is cut).
 * Returns 0, or -1 if too long. */
int host_medium_send(host_medium *m, const uint8_t *frame, uint8_t len);
/* Takes one received frame without blocking (sending the delayed frames
 * that are due first). Returns its length, which may exceed cap (the frame
 * was cut: the caller drops it as too long), or 0 if none. */
int host_medium_recv(host_medium *m, uint8_t *buf, uint8_t cap);
/* Whether the member's link is cut now (see above). */
int host_medium_is_cut(host_medium *m);
/* Milliseconds of CLOCK_MONOTONIC, wrapping. */
uint32_t host_now_ms(void);
/* Sends the delayed frames that are due; returns ms until the next one is
 * due (or `idle_ms` if none). */
int host_medium_flush(host_medium *m, int idle_ms);

#ifdef __cplusplus
}
#endif

#endif
