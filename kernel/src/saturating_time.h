// Time arithmetic that saturates instead of overflowing. A tuple's times are
// i64 microseconds that any PEIS may send (a ts_expire centuries ahead is a
// valid stamp), and durations come from callers and flags, while the timers
// count i64 nanoseconds, which end 292 years after their clock's epoch. Every
// conversion from a tuple's time or a caller's duration to a timer's goes
// through here (docs/tuple-model.md, "Times and their limits"): a wait too
// long for a timer becomes the longest one, never a wrapped negative that
// fires at once (and again, and again).
#pragma once

#include <chrono>
#include <cstdint>
#include <limits>
#include <ratio>

#include "peis/types.h"

namespace peis {

// `d` in the unit of `To`, clamped to To's range.
template <typename To, typename Rep, typename Period>
constexpr To saturatingCast(std::chrono::duration<Rep, Period> d) {
  using Scale = std::ratio_divide<Period, typename To::period>;  // To ticks per tick of d
  if constexpr (Scale::num > Scale::den) {
    static_assert(Scale::den == 1, "a coarser unit is a whole multiple of a finer one");
    constexpr auto most = std::numeric_limits<typename To::rep>::max() / Scale::num;
    constexpr auto least = std::numeric_limits<typename To::rep>::min() / Scale::num;
    if (d.count() > most) return To::max();
    if (d.count() < least) return To::min();
  }
  return std::chrono::duration_cast<To>(d);
}

// a + b and a - b, clamped to the i64 range.
constexpr std::int64_t saturatingAdd(std::int64_t a, std::int64_t b) {
  std::int64_t sum = 0;
  if (!__builtin_add_overflow(a, b, &sum)) return sum;
  return b > 0 ? std::numeric_limits<std::int64_t>::max()
               : std::numeric_limits<std::int64_t>::min();
}
constexpr std::int64_t saturatingSub(std::int64_t a, std::int64_t b) {
  std::int64_t difference = 0;
  if (!__builtin_sub_overflow(a, b, &difference)) return difference;
  return b < 0 ? std::numeric_limits<std::int64_t>::max()
               : std::numeric_limits<std::int64_t>::min();
}

// A time plus a duration, at most the last representable time.
inline Timestamp saturatingAdd(Timestamp t, std::chrono::microseconds d) {
  return Timestamp(
      std::chrono::microseconds(saturatingAdd(t.time_since_epoch().count(), d.count())));
}

// The longest a timer waits at once. A timer due later fires after this, finds
// nothing due and is set again: one wake-up an hour for a far-off time.
inline constexpr std::chrono::hours kLongestTimerWait{1};

// How long a timer waits from `now` until wall-clock time `at`: 0 when `at`
// has passed, at most kLongestTimerWait.
inline std::chrono::steady_clock::duration timerWait(Timestamp at, Timestamp now) {
  const auto left = std::chrono::microseconds(
      saturatingSub(at.time_since_epoch().count(), now.time_since_epoch().count()));
  if (left.count() <= 0) return std::chrono::steady_clock::duration::zero();
  if (left >= kLongestTimerWait) return kLongestTimerWait;
  return saturatingCast<std::chrono::steady_clock::duration>(left);
}

// now + d on the steady clock, at most its last time point.
template <typename Rep, typename Period>
std::chrono::steady_clock::time_point deadlineAfter(std::chrono::steady_clock::time_point now,
                                                    std::chrono::duration<Rep, Period> d) {
  const auto wait = saturatingCast<std::chrono::steady_clock::duration>(d);
  const auto since = now.time_since_epoch().count();
  return std::chrono::steady_clock::time_point(
      std::chrono::steady_clock::duration(saturatingAdd(since, wait.count())));
}

}  // namespace peis
