// Rate and jitter over a window of intervals (kernel/tools/rate.h), against
// values worked out by hand.
#include "rate.h"

#include <catch2/catch.hpp>

using peis::cli::RateWindow;

TEST_CASE("a steady stream: its rate and no jitter", "[unit][cli]") {
  RateWindow window(100);
  CHECK_FALSE(window.stats().has_value());
  window.add(10.0);
  CHECK_FALSE(window.stats().has_value());  // one update is no interval
  for (int i = 1; i <= 10; ++i) window.add(10.0 + 0.1 * i);
  const auto s = window.stats();
  REQUIRE(s.has_value());
  CHECK(s->intervals == 10);
  CHECK(s->rateHz == Approx(10.0));
  CHECK(s->minS == Approx(0.1));
  CHECK(s->maxS == Approx(0.1));
  CHECK(s->stdDevS == Approx(0.0).margin(1e-9));
}

TEST_CASE("an uneven stream: min, max and standard deviation", "[unit][cli]") {
  RateWindow window(100);
  for (double t : {0.0, 0.1, 0.4, 0.5, 0.8}) window.add(t);  // intervals .1 .3 .1 .3
  const auto s = window.stats();
  REQUIRE(s.has_value());
  CHECK(s->meanS == Approx(0.2));
  CHECK(s->rateHz == Approx(5.0));
  CHECK(s->minS == Approx(0.1));
  CHECK(s->maxS == Approx(0.3));
  CHECK(s->stdDevS == Approx(0.1));
}

TEST_CASE("the window keeps only the last N intervals", "[unit][cli]") {
  RateWindow window(3);
  for (double t : {0.0, 1.0, 2.0, 2.5, 3.0, 3.5}) window.add(t);
  const auto s = window.stats();
  REQUIRE(s.has_value());
  CHECK(s->intervals == 3);
  CHECK(s->rateHz == Approx(2.0));
  CHECK(s->maxS == Approx(0.5));
}

TEST_CASE("a time that does not move forward starts over and is counted", "[unit][cli]") {
  RateWindow window(10);
  for (double t : {1.0, 2.0, 2.0, 1.5, 2.5}) window.add(t);
  CHECK(window.outOfOrder() == 2);
  const auto s = window.stats();
  REQUIRE(s.has_value());
  CHECK(s->intervals == 2);  // 1.0 -> 2.0 and 1.5 -> 2.5
  CHECK(s->rateHz == Approx(1.0));
}
