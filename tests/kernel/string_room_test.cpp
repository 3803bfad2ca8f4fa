// Unit tests of net/string_room.h: a string sized for bytes written later
// has exactly that size, whether or not it had to grow.
#include "net/string_room.h"

#include <catch2/catch.hpp>
#include <string>

TEST_CASE("string room: the size asked for, also when the string grows", "[unit]") {
  std::string s = "keep";
  s.reserve(1000);
  const auto capacity = s.capacity();
  // Within twice the capacity: where libstdc++ 12 grows to twice the old
  // capacity and says so to the operation.
  peis::net::resizeForOverwrite(s, capacity + capacity / 2);
  CHECK(s.size() == capacity + capacity / 2);
  CHECK(s.compare(0, 4, "keep") == 0);
  peis::net::resizeForOverwrite(s, 10);
  CHECK(s.size() == 10);
  const auto bigger = 5 * s.capacity();
  peis::net::resizeForOverwrite(s, bigger);
  CHECK(s.size() == bigger);
}
