// Test helper: run an io_context in short turns until a condition holds or
// a deadline passes (the condition is checked between turns, on this
// thread). Returns whether the condition held. A template on the io
// context's type: tests/support/ stays free of Boost (the layering rule).
#pragma once

#include <chrono>
#include <functional>

namespace peis::test {

template <typename IoContext>
bool runIoUntil(IoContext& io, const std::function<bool()>& done,
                std::chrono::milliseconds most = std::chrono::seconds(10)) {
  const auto until = std::chrono::steady_clock::now() + most;
  while (!done() && std::chrono::steady_clock::now() < until) {
    io.restart();
    io.run_for(std::chrono::milliseconds(5));
  }
  return done();
}

}  // namespace peis::test
