// Finger computation; see overlay.h.
#include "net/overlay.h"

#include <algorithm>
#include <array>
#include <cstdint>

namespace peis::net {

std::vector<PeisId> fingers(const std::vector<PeisId>& ids, PeisId a) {
  constexpr std::uint64_t kSpace = 1ull << 31;
  std::array<std::uint64_t, 32> best;
  best.fill(kSpace);
  for (const PeisId x : ids) {
    if (x == a) continue;
    const auto d =
        (static_cast<std::uint64_t>(x) + kSpace - static_cast<std::uint64_t>(a)) % kSpace;
    const auto k = static_cast<std::size_t>(63 - __builtin_clzll(d));
    best[k] = std::min(best[k], d);
  }
  std::vector<PeisId> result;
  for (const auto d : best) {
    if (d < kSpace) {
      result.push_back(static_cast<PeisId>((static_cast<std::uint64_t>(a) + d) % kSpace));
    }
  }
  return result;
}

bool overlayWants(const std::vector<PeisId>& ids, PeisId a, PeisId b) {
  const auto fa = fingers(ids, a);
  if (std::find(fa.begin(), fa.end(), b) != fa.end()) return true;
  const auto fb = fingers(ids, b);
  return std::find(fb.begin(), fb.end(), a) != fb.end();
}

namespace {

constexpr std::uint64_t kRing = 1ull << 31;

std::uint64_t distance(PeisId from, PeisId to) {
  return (static_cast<std::uint64_t>(to) + kRing - static_cast<std::uint64_t>(from)) % kRing;
}

// Whether some id lies in the ring interval [from, to) (from != to).
bool anyIn(const std::vector<PeisId>& sorted, std::uint64_t from, std::uint64_t to) {
  auto at = [&](std::uint64_t v) {
    return std::lower_bound(sorted.begin(), sorted.end(), static_cast<PeisId>(v));
  };
  if (from < to) return at(from) != at(to);
  return at(from) != sorted.end() || at(to) != sorted.begin();  // wraps past 2^31
}

// b is a's finger: no id lies after a+2^k and before b, k being the power of
// two of their distance (the ids nearer than 2^k are in other intervals).
bool isFinger(const std::vector<PeisId>& sorted, PeisId a, PeisId b) {
  const auto d = distance(a, b);
  if (d == 0) return false;
  const auto k = 63 - __builtin_clzll(d);
  const auto from = (static_cast<std::uint64_t>(a) + (1ull << k)) % kRing;
  return from == static_cast<std::uint64_t>(b) ||
         !anyIn(sorted, from, static_cast<std::uint64_t>(b));
}

}  // namespace

bool overlayWantsSorted(const std::vector<PeisId>& sortedIds, PeisId a, PeisId b) {
  return isFinger(sortedIds, a, b) || isFinger(sortedIds, b, a);
}

std::vector<PeisId> overlayPeers(const std::vector<PeisId>& sortedIds, PeisId a) {
  std::vector<PeisId> result;
  for (const PeisId b : sortedIds) {
    if (b != a && overlayWantsSorted(sortedIds, a, b)) result.push_back(b);
  }
  return result;
}

}  // namespace peis::net
