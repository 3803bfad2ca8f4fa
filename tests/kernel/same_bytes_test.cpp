// Unit tests of same_bytes.h: sameBytes agrees with std::string_view's ==
// for every length up to 40 bytes (each of its load widths and the memcmp
// beyond them) and for a difference at every position.
#include "same_bytes.h"

#include <catch2/catch.hpp>
#include <string>

TEST_CASE("sameBytes: equal to == at every length and every differing byte", "[unit]") {
  for (std::size_t n = 0; n <= 40; ++n) {
    std::string a(n, 'k');
    for (std::size_t i = 0; i < n; ++i) a[i] = static_cast<char>('a' + i % 26);
    const std::string same = a;
    CHECK(peis::sameBytes(a, same));
    for (std::size_t i = 0; i < n; ++i) {
      std::string other = a;
      other[i] = static_cast<char>(other[i] ^ 0x20);
      CHECK_FALSE(peis::sameBytes(a, other));
    }
    CHECK_FALSE(peis::sameBytes(a, a + "x"));
    if (n > 0) CHECK_FALSE(peis::sameBytes(a, std::string_view(a).substr(1)));
  }
}
