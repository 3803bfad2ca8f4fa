// The scenario's clock: simulated seconds. With a world, its `sim.time`
// tuple sets the clock (published every 0.1 simulated seconds), and between
// two readings the clock runs on at the run's speed for at most 0.1 s, so a
// world that is stopped or cannot keep up also holds the scenario's time
// back. Without a world, real time times the speed. Scenario time 0 is the
// moment every PEIS had joined (start()); before that there is none.
// Thread-safe; the time source is injected, so tests drive it by hand.
#pragma once

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>

namespace peis::scenario {

class SimClock {
 public:
  using Now = std::function<std::chrono::steady_clock::time_point()>;
  SimClock(double speed, bool fromWorld, Now now = std::chrono::steady_clock::now);

  // A `sim.time` reading of the world.
  void worldTime(double simSeconds);
  // Simulated seconds since the world (or the run) began; nullopt before
  // the world's first reading.
  std::optional<double> simulated() const;
  // Marks scenario time 0 at the current simulated time.
  void start();
  bool started() const;
  // Scenario seconds; nullopt before start() or the world's first reading.
  std::optional<double> now() const;

 private:
  std::optional<double> simulatedLocked() const;
  mutable std::mutex mu_;
  double speed_;
  bool fromWorld_;
  Now clock_;
  std::chrono::steady_clock::time_point begun_, lastAt_;
  std::optional<double> last_;
  std::optional<double> origin_;
};

}  // namespace peis::scenario
