/* The tiny protocol's timings, in one place: read by the tiny kernel on
 * every node and by the tinybridge, which plays a tiny node toward the radio
 * (docs/tiny-tuple.md states what each one means on the air). All are in
 * milliseconds; a build may override any of them with -D, but nodes and the
 * bridge of one radio must agree.
 */
#ifndef TINY_TIMING_H
#define TINY_TIMING_H

#include "tiny_tuple.h" /* TINY_STATIC_ASSERT */

/* Every node (and the bridge) sends a BEACON this often. A beacon whose
 * uptime went back by more than this means its sender restarted. */
#ifndef TINY_BEACON_INTERVAL_MS
#define TINY_BEACON_INTERVAL_MS 1000u
#endif

/* A subscriber sends its SUBSCRIBE again this often (a renewal: the owner
 * answers with its current values, so values lost on the air come back). */
#ifndef TINY_RESUB_INTERVAL_MS
#define TINY_RESUB_INTERVAL_MS 1000u
#endif

/* An owner forgets a subscriber that has not renewed for this long. */
#ifndef TINY_SUBSCRIBER_TIMEOUT_MS
#define TINY_SUBSCRIBER_TIMEOUT_MS (4u * TINY_RESUB_INTERVAL_MS)
#endif

/* A node's neighbour table forgets a neighbour silent for this long. */
#ifndef TINY_NEIGHBOR_TIMEOUT_MS
#define TINY_NEIGHBOR_TIMEOUT_MS (4u * TINY_BEACON_INTERVAL_MS)
#endif

/* The bridge removes a node's proxy PEIS from the ecology when the node has
 * been silent for this long: one beacon longer than a neighbour table
 * waits, since leaving the ecology is seen by every PEIS. */
#ifndef TINY_NODE_TIMEOUT_MS
#define TINY_NODE_TIMEOUT_MS (TINY_NEIGHBOR_TIMEOUT_MS + TINY_BEACON_INTERVAL_MS)
#endif

/* A WRITE has no acknowledgement of its own: the owner's TUPLE frame with
 * the written data confirms it. The writer sends the WRITE again this often
 * until then, and gives up after TINY_WRITE_DEADLINE_MS. */
#ifndef TINY_WRITE_RETRY_MS
#define TINY_WRITE_RETRY_MS 250u
#endif
#ifndef TINY_WRITE_DEADLINE_MS
#define TINY_WRITE_DEADLINE_MS 3000u
#endif

TINY_STATIC_ASSERT(TINY_SUBSCRIBER_TIMEOUT_MS > TINY_RESUB_INTERVAL_MS,
                   "subscribers must outlive one renewal interval");
TINY_STATIC_ASSERT(TINY_NODE_TIMEOUT_MS > TINY_BEACON_INTERVAL_MS,
                   "a node must outlive one beacon interval");
TINY_STATIC_ASSERT(TINY_WRITE_DEADLINE_MS >= TINY_WRITE_RETRY_MS,
                   "a write is sent at least once before its deadline");

#endif /* TINY_TIMING_H */
