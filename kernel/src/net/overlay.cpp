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

}  // namespace peis::net
