// The membership tuples' text (docs/architecture.md, "What the membership
// tuples hold"): ids in decimal, ascending, separated by one space. Pure
// functions of the peers the network reports.
#pragma once

#include <string>
#include <vector>

#include "peis/kernel.h"

namespace peis {

// "12 40 1000" for {12, 40, 1000} (the ids as given, in their order).
std::string joinIds(const std::vector<PeisId>& ids);

struct MembershipText {
  std::string peers;  // kernel.peers: every PEIS in the table but this one
  std::string links;  // kernel.links: those at 1 hop
};
// `peers` is sorted by id (as Kernel::peers() gives them).
MembershipText membershipText(const std::vector<PeerInfo>& peers);

}  // namespace peis
