// The membership tuples' text; see membership.h.
#include "membership.h"

namespace peis {

std::string joinIds(const std::vector<PeisId>& ids) {
  std::string text;
  for (auto id : ids) text += (text.empty() ? "" : " ") + std::to_string(id);
  return text;
}

MembershipText membershipText(const std::vector<PeerInfo>& peers) {
  std::vector<PeisId> ids, linked;
  for (const auto& peer : peers) {
    if (peer.hops > 0) ids.push_back(peer.id);
    if (peer.hops == 1) linked.push_back(peer.id);
  }
  return MembershipText{joinIds(ids), joinIds(linked)};
}

}  // namespace peis
