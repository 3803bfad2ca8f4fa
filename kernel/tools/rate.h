// The rate and jitter of a stream of updates, as `peis hz` reports them
// (after ros2 topic hz): a window of the last N intervals between update
// times, their mean as a rate, their min, max and standard deviation. Pure.
#pragma once

#include <cstddef>
#include <deque>
#include <optional>

namespace peis::cli {

struct RateStats {
  std::size_t intervals = 0;  // in the window
  double rateHz = 0;          // 1 / mean interval
  double meanS = 0, minS = 0, maxS = 0, stdDevS = 0;
};

class RateWindow {
 public:
  explicit RateWindow(std::size_t maxIntervals) : max_(maxIntervals ? maxIntervals : 1) {}
  // One update at `seconds` (any origin, the same for every call). A time
  // not after the previous one starts over from it (a clock that stepped
  // back, or a stamp repeated) and is counted in `outOfOrder`.
  void add(double seconds);
  // Nothing until two updates were seen.
  std::optional<RateStats> stats() const;
  std::size_t outOfOrder() const { return outOfOrder_; }

 private:
  std::size_t max_;
  std::optional<double> last_;
  std::deque<double> intervals_;
  std::size_t outOfOrder_ = 0;
};

}  // namespace peis::cli
