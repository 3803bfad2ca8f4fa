// saturating_time.h: conversions to a timer's nanoseconds and sums of
// microsecond stamps clamp at the ends of their range instead of wrapping
// (a wrapped wait is negative and fires at once, again and again).
#include "saturating_time.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <cstdint>
#include <limits>

using namespace std::chrono_literals;
using peis::Timestamp;
using std::chrono::microseconds;
using std::chrono::nanoseconds;
using Steady = std::chrono::steady_clock;

namespace {
constexpr auto kMost = std::numeric_limits<std::int64_t>::max();
constexpr auto kLeast = std::numeric_limits<std::int64_t>::min();
Timestamp at(std::int64_t micros) { return Timestamp(microseconds(micros)); }
}  // namespace

TEST_CASE("saturatingCast clamps a coarse duration to the finer unit's range", "[unit][time]") {
  CHECK(peis::saturatingCast<nanoseconds>(3ms) == 3'000'000ns);
  CHECK(peis::saturatingCast<nanoseconds>(-3ms) == -3'000'000ns);
  CHECK(peis::saturatingCast<nanoseconds>(std::chrono::milliseconds::max()) == nanoseconds::max());
  CHECK(peis::saturatingCast<nanoseconds>(std::chrono::milliseconds::min()) == nanoseconds::min());
  // 300 years of microseconds: more nanoseconds than an i64 holds (the
  // std::chrono cast would overflow, which is what made the expiry timer spin).
  const auto centuries =
      std::chrono::duration_cast<microseconds>(std::chrono::hours(24 * 365 * 300));
  CHECK(peis::saturatingCast<nanoseconds>(centuries) == nanoseconds::max());
  // Within range it is exact, at the very edge too.
  const auto edge = microseconds(kMost / 1000);
  CHECK(peis::saturatingCast<nanoseconds>(edge).count() == (kMost / 1000) * 1000);
  CHECK(peis::saturatingCast<nanoseconds>(edge + 1us) == nanoseconds::max());
  // To a coarser unit nothing can overflow: it truncates as duration_cast does.
  CHECK(peis::saturatingCast<std::chrono::milliseconds>(1999us) == 1ms);
}

TEST_CASE("saturatingAdd and saturatingSub stay in the i64 range", "[unit][time]") {
  CHECK(peis::saturatingAdd(std::int64_t{2}, std::int64_t{3}) == 5);
  CHECK(peis::saturatingAdd(kMost, std::int64_t{1}) == kMost);
  CHECK(peis::saturatingAdd(kLeast, std::int64_t{-1}) == kLeast);
  CHECK(peis::saturatingSub(std::int64_t{2}, std::int64_t{3}) == -1);
  CHECK(peis::saturatingSub(kMost, std::int64_t{-1}) == kMost);
  CHECK(peis::saturatingSub(kLeast, std::int64_t{1}) == kLeast);
  // A stamp plus the longest ttl is the last representable time, not the past.
  const auto now = at(1'700'000'000'000'000);
  CHECK(peis::saturatingAdd(now, microseconds::max()) == at(kMost));
  CHECK(peis::saturatingAdd(now, 5us) == at(1'700'000'000'000'005));
}

TEST_CASE("timerWait: never negative, at most an hour, exact below", "[unit][time]") {
  const auto now = at(1'700'000'000'000'000);
  CHECK(peis::timerWait(now + 250ms, now) == Steady::duration(250ms));
  CHECK(peis::timerWait(now, now) == Steady::duration::zero());
  CHECK(peis::timerWait(now - 1s, now) == Steady::duration::zero());
  CHECK(peis::timerWait(at(kLeast), now) == Steady::duration::zero());  // the far past
  // Centuries ahead, and the last time there is: an hour, then a re-check.
  CHECK(peis::timerWait(now + std::chrono::hours(24 * 366 * 400), now) == peis::kLongestTimerWait);
  CHECK(peis::timerWait(at(kMost), now) == peis::kLongestTimerWait);
  CHECK(peis::timerWait(at(kMost), at(kLeast)) == peis::kLongestTimerWait);
}

TEST_CASE("deadlineAfter saturates at the steady clock's last time point", "[unit][time]") {
  const auto now = Steady::now();
  CHECK(peis::deadlineAfter(now, 5ms) == now + 5ms);
  CHECK(peis::deadlineAfter(now, std::chrono::milliseconds::max()) == Steady::time_point::max());
  CHECK(peis::deadlineAfter(now, std::chrono::hours::max()) == Steady::time_point::max());
}
