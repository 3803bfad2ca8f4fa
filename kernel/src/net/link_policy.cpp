// Link policy: whom to dial, which links to prune; see link_policy.h.
#include "net/link_policy.h"

#include "net/overlay.h"

namespace peis::net {

std::vector<PeisId> peersToDial(const std::vector<PeisId>& sortedIds, PeisId self,
                                const std::function<bool(PeisId)>& linkedOrDialing, bool all) {
  std::vector<PeisId> dial;
  for (const PeisId target : overlayPeers(sortedIds, self)) {
    if ((all || target > self) && !linkedOrDialing(target)) dial.push_back(target);
  }
  return dial;
}

bool shouldPrune(const std::vector<PeisId>& sortedIds, PeisId self, const PruneQuestion& q) {
  if (!q.discovered || q.peerIsTool || self > q.peer || !q.knownByBeacon) return false;
  if (q.age < kLinkGrace || overlayWantsSorted(sortedIds, self, q.peer)) return false;
  return q.alternative;  // never cut a PEIS off
}

}  // namespace peis::net
