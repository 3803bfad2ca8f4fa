// Link policy: which discovered PEIS to dial and which discovered links to
// close, from the overlay (net/overlay.h) and what the routing table knows
// (docs/protocol.md §6, "Whom to dial"). Pure functions; the Network runs
// them on its timers.
#pragma once

#include <chrono>
#include <functional>
#include <vector>

#include "peis/types.h"

namespace peis::net {

// A discovered link's minimum life, and how long the membership must have
// been stable, before the link may be pruned.
inline constexpr std::chrono::seconds kLinkGrace{2};

// The overlay peers of `self` that it dials: those with a higher id (of a
// wanted pair only the lower id dials; with `all`, as a tool does, every
// one) it is neither linked to nor dialling. `sortedIds`: the known PEIS and
// `self`, ascending.
std::vector<PeisId> peersToDial(const std::vector<PeisId>& sortedIds, PeisId self,
                                const std::function<bool(PeisId)>& linkedOrDialing,
                                bool all = false);

struct PruneQuestion {
  PeisId peer = 0;
  bool discovered = true;  // false: a --peis-connect link, never pruned
  bool knownByBeacon = true;
  std::chrono::steady_clock::duration age{};  // since the link was established
  bool alternative = false;                   // another linked PEIS advertises a route to peer
  bool peerIsTool = false;                    // a tool's links are never pruned: it is short-lived
};
// Whether `self` closes its link to `question.peer`: it is the lower id, the
// peer is no tool, the overlay no longer wants the pair, the link is old
// enough and the peer stays reachable through another neighbour. Call only once the membership has
// been stable for kLinkGrace.
bool shouldPrune(const std::vector<PeisId>& sortedIds, PeisId self, const PruneQuestion& question);

}  // namespace peis::net
