// Rate and jitter over a window of intervals; see rate.h.
#include "rate.h"

#include <algorithm>
#include <cmath>

namespace peis::cli {

void RateWindow::add(double seconds) {
  if (last_ && seconds <= *last_) {
    ++outOfOrder_;
  } else if (last_) {
    intervals_.push_back(seconds - *last_);
    if (intervals_.size() > max_) intervals_.pop_front();
  }
  last_ = seconds;
}

std::optional<RateStats> RateWindow::stats() const {
  if (intervals_.empty()) return std::nullopt;
  RateStats s;
  s.intervals = intervals_.size();
  double sum = 0;
  s.minS = intervals_.front();
  s.maxS = intervals_.front();
  for (double interval : intervals_) {
    sum += interval;
    s.minS = std::min(s.minS, interval);
    s.maxS = std::max(s.maxS, interval);
  }
  s.meanS = sum / static_cast<double>(s.intervals);
  double squares = 0;
  for (double interval : intervals_) squares += (interval - s.meanS) * (interval - s.meanS);
  s.stdDevS = std::sqrt(squares / static_cast<double>(s.intervals));
  s.rateHz = s.meanS > 0 ? 1.0 / s.meanS : 0;
  return s;
}

}  // namespace peis::cli
