// Kernel::waitForPeer on a kernel without network: its own name and id are
// known at once, another name is not, bad names and the kernel thread are
// refused. (Across PEIS: tests/integration/kernel_api_test.cpp.)
#include <atomic>
#include <catch2/catch.hpp>

#include "peis/kernel.h"
#include "support/error_matchers.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::ErrorCode;
using peis::test::HasCode;

namespace {

peis::Options alone(const std::string& name) {
  peis::Options o;
  o.id = 31;
  o.name = name;
  o.network = false;
  o.discovery = false;
  return o;
}

}  // namespace

TEST_CASE("waitForPeer knows this PEIS at once and waits out an unknown one", "[unit][kernel]") {
  peis::Kernel kernel(alone("self"));
  CHECK(kernel.waitForPeer("self", 0ms) == std::optional<peis::PeisId>(31));
  CHECK(kernel.waitForPeer("31", 0ms) == std::optional<peis::PeisId>(31));
  CHECK_FALSE(kernel.waitForPeer("other", 50ms).has_value());
  CHECK_FALSE(kernel.waitForPeer("32", 0ms).has_value());
  REQUIRE_THROWS_MATCHES(kernel.waitForPeer("a.b", 10ms), peis::Error,
                         HasCode(ErrorCode::InvalidName));
}

TEST_CASE("waitForPeer with a timeout is refused on the kernel thread", "[unit][kernel]") {
  peis::Kernel kernel(alone("self"));
  std::atomic<int> outcome{0};  // 1: WouldDeadlock, 2: answered without waiting
  kernel.post([&] {
    try {
      kernel.waitForPeer("other", 100ms);
    } catch (const peis::Error& e) {
      if (e.code() == ErrorCode::WouldDeadlock && kernel.waitForPeer("self", 0ms)) outcome = 1;
      return;
    }
    outcome = 2;
  });
  REQUIRE(peis::test::waitFor([&] { return outcome.load() != 0; }));
  CHECK(outcome == 1);
}
