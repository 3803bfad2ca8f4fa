// Kernel API across PEIS: waitForPeer finds a PEIS that starts later, a
// remote write's ttl makes the owner delete the tuple when it expires, and
// waitForNext wakes with each new value of a subscribed remote tuple.
#include <atomic>
#include <catch2/catch.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "peis/kernel.h"
#include "support/integration.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::test::kDeadline;
using peis::test::kernelOptions;
using peis::test::uniqueEcology;
using peis::test::waitFor;

TEST_CASE("waitForPeer returns once a PEIS of that name is reachable", "[integration]") {
  const auto ecology = uniqueEcology("wait-peer");
  peis::Kernel waiter(kernelOptions(ecology, "waiter"));
  std::optional<peis::PeisId> found;
  std::thread waiting([&] { found = waiter.waitForPeer("late", kDeadline); });
  auto late = std::make_unique<peis::Kernel>(kernelOptions(ecology, "late"));
  waiting.join();
  REQUIRE(found.has_value());
  CHECK(*found == late->id());
  CHECK(waiter.waitForPeer(std::to_string(late->id()), 0ms) == found);
  // Gone again: waiting for it times out.
  const auto lateId = late->id();
  late.reset();
  REQUIRE(waitFor([&] { return !waiter.waitForPeer(std::to_string(lateId), 0ms); }, kDeadline));
  CHECK_FALSE(waiter.waitForPeer("late", 100ms).has_value());
}

TEST_CASE("waitForPeer refuses a name two reachable PEIS carry", "[integration]") {
  const auto ecology = uniqueEcology("wait-twins");
  peis::Kernel waiter(kernelOptions(ecology, "waiter"));
  peis::Kernel one(kernelOptions(ecology, "twin"));
  peis::Kernel two(kernelOptions(ecology, "twin"));
  REQUIRE(waitFor([&] { return waiter.peers().size() == 3; }, kDeadline));
  try {
    waiter.waitForPeer("twin", kDeadline);
    FAIL("expected AmbiguousName");
  } catch (const peis::Error& e) {
    CHECK(e.code() == peis::ErrorCode::AmbiguousName);
  }
}

TEST_CASE("a remote write's ttl: the owner deletes the tuple when it expires", "[integration]") {
  const auto ecology = uniqueEcology("remote-ttl");
  peis::Kernel owner(kernelOptions(ecology, "owner"));
  peis::Kernel writer(kernelOptions(ecology, "writer"));
  REQUIRE(waitFor([&] { return peis::test::hasPeer(writer, owner.id()); }, kDeadline));
  std::atomic<bool> deleted{false};
  owner.onDelete(peis::Pattern::exact(owner.id(), "lease"),
                 [&](const peis::Tuple&) { deleted = true; });
  peis::WriteOptions options;
  options.ttl = 300ms;
  writer.set(owner.id(), "lease", "held", options);
  REQUIRE(waitFor([&] { return deleted.load(); }, kDeadline));
  CHECK_FALSE(owner.get("lease").has_value());
  CHECK(peis::test::valueOf(owner, owner.id(), "kernel.all-keys").find("lease") ==
        std::string::npos);
}

// A value cached by one subscription, asked for again by a second one: the
// owner's full sync brings the same seqno, no change. onChange registered
// then sees nothing of it; onValue hands it over at once, then the changes.
TEST_CASE("onValue hands a remote value already cached, onChange only later changes",
          "[integration]") {
  const auto ecology = uniqueEcology("on-value");
  peis::Kernel owner(kernelOptions(ecology, "owner"));
  peis::Kernel reader(kernelOptions(ecology, "reader"));
  owner.set("x", "1");
  reader.subscribe(peis::Pattern::exact(owner.id(), "x"));
  REQUIRE(waitFor([&] { return reader.get(owner.id(), "x").has_value(); }, kDeadline));
  std::mutex mu;
  std::vector<std::string> values, changes;
  reader.onChange(peis::Pattern::exact(owner.id(), "x"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    changes.push_back(t.data);
  });
  reader.onValue(peis::Pattern::exact(owner.id(), "x"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    values.push_back(t.data);
  });
  reader.subscribe(peis::Pattern::exact(owner.id(), "x"));  // a second full sync: the same seqno
  owner.set("x", "2");
  REQUIRE(waitFor(
      [&] {
        std::lock_guard lock(mu);
        return values.size() == 2 && changes.size() == 1;
      },
      kDeadline));
  std::lock_guard lock(mu);
  CHECK(values == std::vector<std::string>{"1", "2"});
  CHECK(changes == std::vector<std::string>{"2"});
}

TEST_CASE("waitForNext wakes with each new value of a subscribed remote tuple", "[integration]") {
  const auto ecology = uniqueEcology("wait-for-next");
  peis::Kernel owner(kernelOptions(ecology, "owner"));
  peis::Kernel reader(kernelOptions(ecology, "reader"));
  reader.subscribe(peis::Pattern::exact(owner.id(), "reply"));
  REQUIRE(waitFor([&] { return peis::test::hasPeer(reader, owner.id()); }, kDeadline));
  // Request and reply, as a thread that waits for each answer does: the
  // owner answers every request, the reader waits for the answer.
  owner.onChange(peis::Pattern::exact(reader.id(), "request"),
                 [&](const peis::Tuple& t) { owner.publish("reply", t.data); });
  owner.subscribe(peis::Pattern::exact(reader.id(), "request"));
  REQUIRE(waitFor(
      [&] { return reader.get(peis::special::kSubscribers)->data == std::to_string(owner.id()); },
      kDeadline));
  std::uint64_t seen = 0;
  for (int i = 0; i < 20; ++i) {
    // Up to 76 KB: big values are read straight into their tuple.
    const auto request = std::to_string(i) + std::string(static_cast<std::size_t>(i) * 4000, 'x');
    reader.publish("request", request);
    const auto reply = reader.waitForNext(owner.id(), "reply", seen, kDeadline);
    REQUIRE(reply != nullptr);
    CHECK(reply->owner == owner.id());
    CHECK(reply->data == request);
    seen = reply->seqno;
  }
}
