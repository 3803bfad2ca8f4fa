// The benchmark peers users would pick instead of PEIS (Cyclone DDS, ZeroMQ),
// measured the way peis-bench-net measures the ecology: a round trip between
// two processes and a one-way stream to one subscriber that keeps up.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "../bench_stats.h"

namespace peis::bench {

struct StreamResult {
  double deliveredPerSecond = 0;
  std::uint64_t delivered = 0, written = 0;
};

// Cyclone DDS: reliable, keep-last-1, a listener on the receiving side (round
// trip); reliable keep-all (stream, so nothing is lost). Loopback only,
// multicast off (see dds_peer.cpp).
Percentiles ddsRoundTrip(std::size_t bytes, int count);
StreamResult ddsStream(std::size_t bytes, double seconds);
int ddsEchoRole(int domain);
int ddsSinkRole(int domain);

// ZeroMQ PUB/SUB over TCP on loopback; a publisher that never drops
// (ZMQ_XPUB_NODROP, the sender waits) so the subscriber keeps up.
Percentiles zmqRoundTrip(std::size_t bytes, int count);
StreamResult zmqStream(std::size_t bytes, double seconds);
int zmqEchoRole(int parentPort);
int zmqSinkRole(int parentPort);

}  // namespace peis::bench
