// The overlay: which pairs of PEIS keep a link, computed by every PEIS from
// the ids it knows, with no coordination (docs/protocol.md §6). Pure
// functions.
//
// The fingers of PEIS `a` are, for every k, the known PEIS closest after `a`
// at an id distance in [2^k, 2^(k+1)), ids wrapping at 2^31 (Chord's fingers
// in id space). A pair is wanted when either is a finger of the other. The
// nearest finger (the successor) closes a ring over all known PEIS, so the
// overlay is connected; each PEIS has O(log N) links and paths are O(log N)
// hops; a joining PEIS moves only the fingers it lands closest in.
#pragma once

#include <vector>

#include "peis/types.h"

namespace peis::net {

// `ids` may be in any order and may contain `a`.
std::vector<PeisId> fingers(const std::vector<PeisId>& ids, PeisId a);
bool overlayWants(const std::vector<PeisId>& ids, PeisId a, PeisId b);

// The same on ids sorted ascending without duplicates (which must hold `a`
// and `b`): O(log N) a pair, by binary search, instead of O(N).
bool overlayWantsSorted(const std::vector<PeisId>& sortedIds, PeisId a, PeisId b);
// Every b that overlayWants(ids, a, b), ascending: O(N log N).
std::vector<PeisId> overlayPeers(const std::vector<PeisId>& sortedIds, PeisId a);

}  // namespace peis::net
