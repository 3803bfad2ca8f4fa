// "Did you mean": edit distance and the closest names (kernel/tools/suggest.h).
#include "suggest.h"

#include <catch2/catch.hpp>

using peis::cli::closestNames;
using peis::cli::didYouMean;
using peis::cli::editDistance;
using Names = std::vector<std::string>;

TEST_CASE("edit distance counts inserts, deletes, replacements and swaps", "[unit][cli]") {
  CHECK(editDistance("", "") == 0);
  CHECK(editDistance("abc", "") == 3);
  CHECK(editDistance("", "abc") == 3);
  CHECK(editDistance("position", "position") == 0);
  CHECK(editDistance("postion", "position") == 1);    // a letter left out
  CHECK(editDistance("positionn", "position") == 1);  // one too many
  CHECK(editDistance("posituon", "position") == 1);   // one replaced
  CHECK(editDistance("lmap", "lamp") == 1);           // neighbours swapped
  CHECK(editDistance("kitten", "sitting") == 3);
}

TEST_CASE("the closest names: closest first, ties by name, far ones left out", "[unit][cli]") {
  const Names keys{"position", "posture", "light.reqState", "status", "kernel.name"};
  CHECK(closestNames("postion", keys) == Names{"position"});
  CHECK(closestNames("statsu", keys) == Names{"status"});
  CHECK(closestNames("temperature", keys).empty());
  CHECK(closestNames("Position", keys) == Names{"position"});  // case alone is a near miss
  CHECK(closestNames("position", keys).empty());               // itself is no suggestion
  CHECK(closestNames("ab", Names{"ac", "ad", "xy", "ab"}) == Names{"ac", "ad"});
  CHECK(closestNames("a", Names{"b", "c", "d", "e"}, 2) == Names{"b", "c"});
}

TEST_CASE("did-you-mean text for none, one and several names", "[unit][cli]") {
  CHECK(didYouMean({}).empty());
  CHECK(didYouMean({"position"}) == "; did you mean 'position'?");
  CHECK(didYouMean({"a", "b"}) == "; did you mean 'a' or 'b'?");
  CHECK(didYouMean({"a", "b", "c"}) == "; did you mean 'a', 'b' or 'c'?");
}
