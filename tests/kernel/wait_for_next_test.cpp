// Kernel::waitForNext on a kernel without network: a value other than the
// one seen returns at once, a later set from another thread wakes the
// waiter, the deadline gives null, and the kernel thread may not wait.
// (Across PEIS: tests/integration/kernel_api_test.cpp.)
#include <atomic>
#include <catch2/catch.hpp>
#include <memory>
#include <thread>

#include "peis/kernel.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::ErrorCode;

namespace {

peis::Options alone() {
  peis::Options o;
  o.id = 41;
  o.name = "self";
  o.network = false;
  o.discovery = false;
  return o;
}

}  // namespace

TEST_CASE("waitForNext returns a value it has not seen at once, else null at the deadline",
          "[unit][kernel]") {
  peis::Kernel kernel(alone());
  CHECK(kernel.waitForNext(41, "x", 0, 0ms) == nullptr);
  CHECK(kernel.waitForNext(41, "x", 0, 20ms) == nullptr);
  const auto seqno = kernel.publish("x", "1");
  const auto first = kernel.waitForNext(41, "x", 0, 0ms);
  REQUIRE(first != nullptr);
  CHECK(first->data == "1");
  CHECK(first->seqno == seqno);
  CHECK(kernel.waitForNext(41, "x", seqno, 0ms) == nullptr);
  CHECK(kernel.waitForNext(41, "x", seqno, 20ms) == nullptr);
  // The value handed out is the stored one, shared: a later set leaves it.
  kernel.publish("x", "2");
  CHECK(first->data == "1");
  const auto second = kernel.waitForNext(41, "x", seqno, 0ms);
  REQUIRE(second != nullptr);
  CHECK(second->data == "2");
}

TEST_CASE("waitForNext wakes when another thread sets the tuple", "[unit][kernel]") {
  peis::Kernel kernel(alone());
  const auto seen = kernel.publish("x", "old");
  std::atomic<bool> waiting{false};
  std::shared_ptr<const peis::Tuple> got;
  std::thread waiter([&] {
    waiting = true;
    got = kernel.waitForNext(41, "x", seen, 10s);
  });
  REQUIRE(peis::test::waitFor([&] { return waiting.load(); }));
  kernel.publish("x", "new");
  waiter.join();
  REQUIRE(got != nullptr);
  CHECK(got->data == "new");
  CHECK(got->seqno > seen);
}

TEST_CASE("waitForNext sees values set on the kernel thread", "[unit][kernel]") {
  peis::Kernel kernel(alone());
  kernel.every(1ms, [&] { kernel.publish("tick", "t"); });
  std::uint64_t seen = 0;
  for (int i = 0; i < 5; ++i) {
    const auto next = kernel.waitForNext(41, "tick", seen, 10s);
    REQUIRE(next != nullptr);
    CHECK(next->seqno != seen);
    seen = next->seqno;
  }
}

TEST_CASE("waitForNext with a wait is refused on the kernel thread", "[unit][kernel]") {
  peis::Kernel kernel(alone());
  kernel.publish("x", "1");
  std::atomic<int> outcome{0};  // 1: WouldDeadlock, and 0ms answers; 2: waited
  kernel.post([&] {
    try {
      kernel.waitForNext(41, "x", 1, 100ms);
    } catch (const peis::Error& e) {
      if (e.code() == ErrorCode::WouldDeadlock && kernel.waitForNext(41, "x", 0, 0ms)) {
        outcome = 1;
      }
      return;
    }
    outcome = 2;
  });
  REQUIRE(peis::test::waitFor([&] { return outcome.load() != 0; }));
  CHECK(outcome == 1);
}

TEST_CASE("waitForNext sees kernel.all-keys change when a key is added", "[unit][kernel]") {
  peis::Kernel kernel(alone());
  const auto before = kernel.waitForNext(41, peis::special::kAllKeys, 0, 10s);
  REQUIRE(before != nullptr);
  CHECK(before->data.find("added") == std::string::npos);
  std::shared_ptr<const peis::Tuple> after;
  std::thread waiter(
      [&] { after = kernel.waitForNext(41, peis::special::kAllKeys, before->seqno, 10s); });
  kernel.publish("added", "1");
  waiter.join();
  REQUIRE(after != nullptr);
  CHECK(after->data.find("added") != std::string::npos);
}
