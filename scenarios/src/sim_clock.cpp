// The scenario's clock; see sim_clock.h.
#include "sim_clock.h"

#include <algorithm>

namespace peis::scenario {
namespace {
// The world publishes sim.time every 0.1 simulated seconds.
constexpr double kMaxRunOn = 0.1;
}  // namespace

SimClock::SimClock(double speed, bool fromWorld, Now now)
    : speed_(speed), fromWorld_(fromWorld), clock_(std::move(now)), begun_(clock_()) {}

void SimClock::worldTime(double simSeconds) {
  std::lock_guard lock(mu_);
  if (last_ && simSeconds < *last_) return;  // a late reading
  last_ = simSeconds;
  lastAt_ = clock_();
}

std::optional<double> SimClock::simulatedLocked() const {
  const auto real = [&](auto since) {
    return std::chrono::duration<double>(clock_() - since).count() * speed_;
  };
  if (!fromWorld_) return real(begun_);
  if (!last_) return std::nullopt;
  return *last_ + std::clamp(real(lastAt_), 0.0, kMaxRunOn);
}

std::optional<double> SimClock::simulated() const {
  std::lock_guard lock(mu_);
  return simulatedLocked();
}

void SimClock::start() {
  std::lock_guard lock(mu_);
  origin_ = simulatedLocked().value_or(0);
}

bool SimClock::started() const {
  std::lock_guard lock(mu_);
  return origin_.has_value();
}

std::optional<double> SimClock::now() const {
  std::lock_guard lock(mu_);
  const auto sim = simulatedLocked();
  if (!sim || !origin_) return std::nullopt;
  return *sim - *origin_;
}

}  // namespace peis::scenario
