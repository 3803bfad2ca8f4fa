// Subscriptions made while the route to the owner is still being learnt: a
// chain A - B - C (A a separate `peis node` process, B and C Kernels of the
// test, over loopback), C subscribing to A's tuples before A is reachable,
// in every start order, many times; then the middle PEIS replaced (the
// route lost and found again) and a new value of A written by C. Each
// value reaches C within the deadline or the test names what C held.
#include <signal.h>

#include <catch2/catch.hpp>
#include <memory>
#include <optional>
#include <string>

#include "peis/kernel.h"
#include "support/integration.h"

using namespace std::chrono_literals;
using peis::test::hasPeer;
using peis::test::kernelOptions;
using peis::test::localhost;
using peis::test::peersText;
using peis::test::Process;
using peis::test::uniqueEcology;
using peis::test::valueOf;
using peis::test::waitFor;

namespace {

constexpr auto kDeadline = std::chrono::milliseconds(30s);

// A: a `peis node` process holding a.x = 1, dialling B (the chain only: no discovery).
std::unique_ptr<Process> startA(const std::string& ecology, std::uint16_t bPort) {
  return peis::test::startNode(
      ecology, {"--peis-name", "a", "--peis-no-discovery", "--peis-connect", localhost(bPort),
                "--peis-set-tuple", "x=1"});
}

}  // namespace

TEST_CASE("a subscription made before the route to its owner exists gets the owner's tuples",
          "[integration]") {
  enum class Order { BThenAThenC, CThenBThenA, BThenCThenA };
  for (const auto order : {Order::BThenAThenC, Order::CThenBThenA, Order::BThenCThenA}) {
    for (int round = 0; round < 4; ++round) {
      const auto ecology = uniqueEcology("subroute");
      std::unique_ptr<peis::Kernel> b, c;
      std::unique_ptr<Process> a;
      // C subscribes to x of any owner at once, before it reaches anyone.
      auto makeC = [&](std::optional<std::uint16_t> dial) {
        c = std::make_unique<peis::Kernel>(
            kernelOptions(ecology, "c", false,
                          dial ? std::vector{localhost(*dial)} : std::vector<std::string>{}));
        c->subscribe(peis::Pattern("x"));
      };
      auto makeB = [&](std::optional<std::uint16_t> dial) {
        b = std::make_unique<peis::Kernel>(
            kernelOptions(ecology, "b", false,
                          dial ? std::vector{localhost(*dial)} : std::vector<std::string>{}));
      };
      switch (order) {
        case Order::BThenAThenC:
          makeB(std::nullopt);
          a = startA(ecology, b->port());
          makeC(b->port());
          break;
        case Order::CThenBThenA:
          makeC(std::nullopt);
          makeB(c->port());
          a = startA(ecology, b->port());
          break;
        case Order::BThenCThenA:
          makeB(std::nullopt);
          makeC(b->port());
          a = startA(ecology, b->port());
          break;
      }
      const peis::PeisId aId = peis::test::awaitNode(*a).id;
      INFO("order " << static_cast<int>(order) << ", round " << round);
      INFO("c sees: " << peersText(*c) << "\n" << a->describe());
      REQUIRE(waitFor([&] { return valueOf(*c, aId, "x") == "1"; }, kDeadline));
      // The middle PEIS replaced: C loses its route to A and learns it anew;
      // a value of A written meanwhile by C comes back to C.
      const auto bPort = b->port();
      b.reset();
      REQUIRE(waitFor([&] { return !hasPeer(*c, aId); }, kDeadline));
      auto o = kernelOptions(ecology, "b", false, {localhost(c->port())});
      o.port = bPort;  // where A dials it again
      b = std::make_unique<peis::Kernel>(o);
      REQUIRE(c->waitForPeer(std::to_string(aId), kDeadline).has_value());
      c->set(aId, "x", "2");
      INFO("after the route came back, c sees: " << peersText(*c));
      REQUIRE(waitFor([&] { return valueOf(*c, aId, "x") == "2"; }, kDeadline));
      a->kill(SIGTERM);
      a->wait(kDeadline);
    }
  }
}
