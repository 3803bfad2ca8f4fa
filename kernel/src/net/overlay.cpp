// Ring positions and fingers; see overlay.h.
#include "net/overlay.h"

#include <algorithm>
#include <array>

namespace peis::net {

namespace {

constexpr std::uint64_t kRing = 1ull << 31;

std::uint64_t distance(std::uint64_t from, std::uint64_t to) { return (to + kRing - from) % kRing; }

}  // namespace

// Multiplying by an odd number and xor-shifting right are each invertible
// modulo 2^31, so no two ids share a position; two rounds scatter runs of
// consecutive ids over the whole ring.
std::uint32_t ringPosition(PeisId id) {
  std::uint64_t x = static_cast<std::uint32_t>(id) & (kRing - 1);
  x = (x * 0x9E3779B1ull) & (kRing - 1);
  x ^= x >> 15;
  x = (x * 0x85EBCA77ull) & (kRing - 1);
  x ^= x >> 13;
  return static_cast<std::uint32_t>(x);
}

std::vector<PeisId> fingers(const std::vector<PeisId>& ids, PeisId a) {
  std::array<std::uint64_t, 32> best;
  best.fill(kRing);
  std::array<PeisId, 32> who{};
  const std::uint64_t from = ringPosition(a);
  for (const PeisId x : ids) {
    if (x == a) continue;
    const auto d = distance(from, ringPosition(x));
    const auto k = static_cast<std::size_t>(63 - __builtin_clzll(d));
    if (d < best[k]) {
      best[k] = d;
      who[k] = x;
    }
  }
  std::vector<PeisId> result;
  for (std::size_t k = 0; k < best.size(); ++k) {
    if (best[k] < kRing) result.push_back(who[k]);
  }
  return result;
}

bool overlayWants(const std::vector<PeisId>& ids, PeisId a, PeisId b) {
  const auto fa = fingers(ids, a);
  if (std::find(fa.begin(), fa.end(), b) != fa.end()) return true;
  const auto fb = fingers(ids, b);
  return std::find(fb.begin(), fb.end(), a) != fb.end();
}

Ring::Ring(const std::vector<PeisId>& ids) {
  ring_.reserve(ids.size());
  for (const PeisId id : ids) ring_.emplace_back(ringPosition(id), id);
  std::sort(ring_.begin(), ring_.end());
  ring_.erase(std::unique(ring_.begin(), ring_.end()), ring_.end());
}

void Ring::insert(PeisId id) {
  const std::pair<std::uint32_t, PeisId> entry(ringPosition(id), id);
  const auto at = std::lower_bound(ring_.begin(), ring_.end(), entry);
  if (at == ring_.end() || *at != entry) ring_.insert(at, entry);
}

void Ring::erase(PeisId id) {
  const std::pair<std::uint32_t, PeisId> entry(ringPosition(id), id);
  const auto at = std::lower_bound(ring_.begin(), ring_.end(), entry);
  if (at != ring_.end() && *at == entry) ring_.erase(at);
}

bool Ring::anyIn(std::uint64_t from, std::uint64_t to) const {
  auto at = [&](std::uint64_t position) {
    return std::lower_bound(
        ring_.begin(), ring_.end(),
        std::pair<std::uint32_t, PeisId>(static_cast<std::uint32_t>(position), 0));
  };
  if (from < to) return at(from) != at(to);
  return at(from) != ring_.end() || at(to) != ring_.begin();  // wraps past 2^31
}

// b is a's finger: no PEIS lies after a+2^k and before b, k being the power
// of two of their distance (those nearer than 2^k are in other intervals).
bool Ring::isFinger(PeisId a, PeisId b) const {
  const std::uint64_t pa = ringPosition(a), pb = ringPosition(b);
  const auto d = distance(pa, pb);
  if (d == 0) return false;
  const auto k = 63 - __builtin_clzll(d);
  const auto from = (pa + (1ull << k)) % kRing;
  return from == pb || !anyIn(from, pb);
}

bool Ring::wants(PeisId a, PeisId b) const { return isFinger(a, b) || isFinger(b, a); }

std::vector<PeisId> Ring::peers(PeisId a) const {
  std::vector<PeisId> result;
  for (const auto& [position, b] : ring_) {
    if (b != a && wants(a, b)) result.push_back(b);
  }
  std::sort(result.begin(), result.end());
  return result;
}

PeisId Ring::successor(PeisId a) const {
  const auto position = ringPosition(a);
  auto it = std::upper_bound(ring_.begin(), ring_.end(),
                             std::pair<std::uint32_t, PeisId>(position, kMaxPeisId));
  if (it == ring_.end()) it = ring_.begin();  // wraps
  if (it == ring_.end() || it->second == a) return 0;
  return it->second;
}

PeisId Ring::predecessor(PeisId a) const {
  const auto position = ringPosition(a);
  auto it =
      std::lower_bound(ring_.begin(), ring_.end(), std::pair<std::uint32_t, PeisId>(position, 0));
  if (it == ring_.begin()) it = ring_.end();  // wraps
  if (ring_.empty()) return 0;
  --it;
  return it->second == a ? 0 : it->second;
}

bool overlayWantsSorted(const std::vector<PeisId>& ids, PeisId a, PeisId b) {
  return Ring(ids).wants(a, b);
}

std::vector<PeisId> overlayPeers(const std::vector<PeisId>& ids, PeisId a) {
  return Ring(ids).peers(a);
}

}  // namespace peis::net
