// sameBytes: whether two short byte strings are equal, inline. The
// receive path compares a stream's key and mimetype several times per
// update (with the stored value, the last entry, the matched callbacks);
// std::string's == calls memcmp each time, whose call and dispatch cost
// more than comparing a key of a few bytes.
#pragma once

#include <cstdint>
#include <cstring>
#include <string_view>

namespace peis {

// Whether n bytes (sizeof(Word) <= n <= 2 * sizeof(Word)) at x and y are
// equal: two overlapping word loads from each, no call.
template <typename Word>
[[gnu::always_inline]] inline bool sameInTwoLoads(const char* x, const char* y, std::size_t n) {
  Word a0, a1, b0, b1;
  std::memcpy(&a0, x, sizeof(Word));
  std::memcpy(&b0, y, sizeof(Word));
  std::memcpy(&a1, x + n - sizeof(Word), sizeof(Word));
  std::memcpy(&b1, y + n - sizeof(Word), sizeof(Word));
  return ((a0 ^ b0) | (a1 ^ b1)) == 0;
}

[[gnu::always_inline]] inline bool sameBytes(std::string_view a, std::string_view b) {
  const std::size_t n = a.size();
  if (n != b.size()) return false;
  const char* x = a.data();
  const char* y = b.data();
  if (n >= 8 && n <= 16) return sameInTwoLoads<std::uint64_t>(x, y, n);
  if (n >= 4 && n < 8) return sameInTwoLoads<std::uint32_t>(x, y, n);
  if (n < 4) {
    for (std::size_t i = 0; i < n; ++i) {
      if (x[i] != y[i]) return false;
    }
    return true;
  }
  return std::memcmp(x, y, n) == 0;
}

}  // namespace peis
