// The overlay: which pairs of PEIS keep a link, computed by every PEIS from
// the ids it knows, with no coordination (docs/protocol.md §6). Pure
// functions.
//
// Every id has a position on a ring of 2^31 (ringPosition: a fixed
// bijection that scatters ids, as Chord hashes its node names). The fingers
// of PEIS `a` are, for every k, the known PEIS closest after `a` at a ring
// distance in [2^k, 2^(k+1)) (Chord's fingers). A pair is wanted when either
// is a finger of the other. The nearest finger (the successor) closes a ring
// over all known PEIS, so the overlay is connected; each PEIS has O(log N)
// links and paths are O(log N) hops; a joining PEIS moves only the fingers
// it lands closest in. On raw ids, ids given in a run (1000, 1001, ...) sit
// in a tiny arc of the ring, and every PEIS's far fingers all fell on the
// lowest id: one PEIS linked with everybody. Scattered, no PEIS is much
// busier than another, whatever ids the ecology uses.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "peis/types.h"

namespace peis::net {

// The ring position of an id: a bijection of [0, 2^31).
std::uint32_t ringPosition(PeisId id);

// The known PEIS on the ring, for O(log N) questions about one membership.
class Ring {
 public:
  Ring() = default;
  // `ids` may be in any order and hold duplicates.
  explicit Ring(const std::vector<PeisId>& ids);
  // Whether a and b (both on the ring) keep a link.
  bool wants(PeisId a, PeisId b) const;
  // Puts one PEIS on the ring or takes it off: O(N), where building it
  // again sorts (a join of N PEIS changes each PEIS's ring N times).
  void insert(PeisId id);
  void erase(PeisId id);
  // Every b that wants(a, b), ascending.
  std::vector<PeisId> peers(PeisId a) const;
  // The PEIS nearest after and before `a` on the ring (`a` need not be on
  // it; 0 when there is no other).
  PeisId successor(PeisId a) const;
  PeisId predecessor(PeisId a) const;
  std::size_t size() const { return ring_.size(); }

 private:
  bool isFinger(PeisId a, PeisId b) const;
  // Whether some PEIS lies in the ring interval [from, to) (from != to).
  bool anyIn(std::uint64_t from, std::uint64_t to) const;
  std::vector<std::pair<std::uint32_t, PeisId>> ring_;  // (position, id), by position
};

// `ids` may be in any order and may contain `a`: the reference definition,
// O(N) a PEIS.
std::vector<PeisId> fingers(const std::vector<PeisId>& ids, PeisId a);
bool overlayWants(const std::vector<PeisId>& ids, PeisId a, PeisId b);

// The same through a Ring built for the call (O(N log N)); `ids` must hold
// `a` and `b`.
bool overlayWantsSorted(const std::vector<PeisId>& ids, PeisId a, PeisId b);
// Every b that overlayWants(ids, a, b), ascending.
std::vector<PeisId> overlayPeers(const std::vector<PeisId>& ids, PeisId a);

}  // namespace peis::net
