// How often a tuple changes, as the view measures it: the arrival times of
// its last updates, kept in a small ring, give updates per second over the
// time from the oldest of them that is within the window to now. Measuring
// up to now (not to the last arrival) makes the rate fall towards zero once
// a tuple stops changing. Pure; the caller passes the times.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>

#include "peis/types.h"

namespace peis::view {

class RateMeter {
 public:
  static constexpr std::size_t kArrivals = 32;
  static constexpr std::chrono::seconds kWindow{10};

  void add(Timestamp arrival) {
    arrivals_[next_] = arrival;
    next_ = (next_ + 1) % kArrivals;
    if (count_ < kArrivals) ++count_;
  }

  // Updates per second at `now`: (n - 1) / (now - oldest) over the n
  // arrivals within the window; 0 with fewer than two.
  double rate(Timestamp now) const {
    std::size_t within = 0;
    Timestamp oldest = now;
    for (std::size_t i = 0; i < count_; ++i) {
      const Timestamp t = arrivals_[i];
      if (now - t > kWindow || t > now) continue;
      ++within;
      if (t < oldest) oldest = t;
    }
    if (within < 2) return 0.0;
    const double seconds = std::chrono::duration<double>(now - oldest).count();
    return seconds > 0 ? static_cast<double>(within - 1) / seconds : 0.0;
  }

 private:
  std::array<Timestamp, kArrivals> arrivals_{};
  std::size_t next_ = 0;
  std::size_t count_ = 0;
};

}  // namespace peis::view
