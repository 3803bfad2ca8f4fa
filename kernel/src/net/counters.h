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
  // Limits against misbehaving peers (docs/security.md, "Limits"):
  std::uint64_t handshakeTimeouts = 0;   // connections closed at the handshake deadline
  std::uint64_t connectionsRefused = 0;  // accepted connections over a connection cap
  std::uint64_t routesRefused = 0;       // route entries over --peis-max-routes
  std::uint64_t heldFramesDropped = 0;   // frames over the held limit (also unroutable)
  // Secured ecologies (docs/security.md):
  std::uint64_t authRefused = 0;  // links refused at the handshake (with the reason logged)
  std::uint64_t unentitled = 0;   // routes, identities, relayed frames no PEIS proved
};

}  // namespace peis::net
