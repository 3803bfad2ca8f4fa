// Counters of the network layer: what it received, sent, dropped and
// refused. docs/protocol.md says what each counts; Kernel::networkStats()
// reports them as peis::NetworkStats.
#pragma once

#include <atomic>
#include <cstdint>

namespace peis::net {

struct Counters {
  std::uint64_t framesIn = 0;
  std::uint64_t framesOut = 0;
  // Frames sent by direct sends (Link::sendNow), from any thread; part of
  // framesOut in NetworkStats.
  std::atomic<std::uint64_t> directFramesOut{0};
  std::uint64_t malformedFrames = 0;
  std::uint64_t garbagePeersDisconnected = 0;
  std::uint64_t foreignEcologyRejected = 0;
  std::uint64_t unroutable = 0;
  std::uint64_t coalesced = 0;
  std::uint64_t idCollisions = 0;
  std::uint64_t malformedBeacons = 0;
  std::uint64_t beaconsSuppressed = 0;      // periodic beacons skipped (docs/protocol.md §6)
  std::uint64_t slowPeersDisconnected = 0;  // links closed for reading too slowly (§13)
};

}  // namespace peis::net
