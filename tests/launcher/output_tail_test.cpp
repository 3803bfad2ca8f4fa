// The last lines of a launched program's output, in any pieces.
#include "launcher/output_tail.h"

#include <catch2/catch.hpp>

using peis::launcher::OutputTail;

TEST_CASE("output tail keeps the last lines, the unfinished one included", "[unit]") {
  OutputTail tail(3);
  CHECK(tail.text().empty());
  CHECK_FALSE(tail.takeChanged());
  tail.append("one\ntw");
  CHECK(tail.takeChanged());
  CHECK(tail.text() == "one\ntw");
  tail.append("o\nthree\nfour\n");
  CHECK(tail.text() == "two\nthree\nfour");
  tail.append("fi");
  CHECK(tail.text() == "three\nfour\nfi");
  tail.clear();
  CHECK(tail.takeChanged());
  CHECK(tail.text().empty());
}

TEST_CASE("output tail cuts long lines and keeps nothing with 0 lines", "[unit]") {
  OutputTail tail(2);
  tail.append(std::string(5000, 'x') + "\nend\n");
  CHECK(tail.text() == std::string(OutputTail::kMaxLineBytes, 'x') + "...\nend");
  OutputTail none(0);
  none.append("a\nb\n");
  CHECK(none.text().empty());
  CHECK_FALSE(none.takeChanged());
}
