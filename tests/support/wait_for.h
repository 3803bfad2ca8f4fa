// Test helper: wait for a condition with a deadline instead of sleeping and
// hoping. Polls every millisecond; returns whether the condition held.
#pragma once

#include <chrono>
#include <functional>
#include <thread>

#include "peis/types.h"

namespace peis::test {

inline bool waitFor(const std::function<bool()>& condition,
                    std::chrono::milliseconds deadline = std::chrono::seconds(10)) {
  const auto until = std::chrono::steady_clock::now() + deadline;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= until) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

// A clock tests move by hand.
struct ManualClock {
  Timestamp now = Timestamp(std::chrono::seconds(1'700'000'000));
  void advance(std::chrono::microseconds by) { now += by; }
};

}  // namespace peis::test
