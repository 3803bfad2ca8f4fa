// Unit tests of the pure decisions around links: the handshake's verdict on
// a Hello (net/handshake.h) and whom to dial and which links to prune
// (net/link_policy.h), tool PEIS included.
#include "net/link_policy.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <optional>

#include "net/handshake.h"
#include "net/overlay.h"

using peis::PeisId;
using namespace peis::net;
using namespace std::chrono_literals;

namespace {

peis::wire::Hello helloFrom(PeisId id, std::uint64_t incarnation, std::string ecology = "eco") {
  peis::wire::Hello h;
  h.ecology = std::move(ecology);
  h.id = id;
  h.incarnation = incarnation;
  return h;
}

}  // namespace

TEST_CASE("handshake: the verdict on a Hello", "[unit][handshake]") {
  HelloContext c{10, 100, "eco"};
  CHECK(judgeHello(c, helloFrom(20, 1)) == HelloVerdict::Establish);
  auto old = helloFrom(20, 1);
  old.version = peis::wire::kVersion + 1;
  CHECK(judgeHello(c, old) == HelloVerdict::WrongVersion);
  CHECK(judgeHello(c, helloFrom(20, 1, "other")) == HelloVerdict::ForeignEcology);
  CHECK(judgeHello(c, helloFrom(10, 100)) == HelloVerdict::Myself);
  CHECK(judgeHello(c, helloFrom(10, 200)) == HelloVerdict::IdMine);   // it started later
  CHECK(judgeHello(c, helloFrom(10, 50)) == HelloVerdict::IdTheirs);  // it started earlier
  auto established = c;
  established.established = true;
  CHECK(judgeHello(established, helloFrom(20, 1)) == HelloVerdict::Ignore);

  const auto existing = helloFrom(20, 1);
  auto second = c;
  second.existing = &existing;
  CHECK(judgeHello(second, helloFrom(20, 2)) == HelloVerdict::OtherIncarnationLinked);
  // Of two links between 10 and 20 both keep the one 10 (the lower id) dialled.
  second.outbound = true;
  second.existingOutbound = false;
  CHECK(judgeHello(second, helloFrom(20, 1)) == HelloVerdict::ReplacesExisting);
  second.outbound = false;
  second.existingOutbound = true;
  CHECK(judgeHello(second, helloFrom(20, 1)) == HelloVerdict::Duplicate);
}

TEST_CASE("link policy: the lower id dials, a tool dials all its overlay peers",
          "[unit][link-policy]") {
  const std::vector<PeisId> ids{10, 11, 12, 14, 30};
  auto none = [](PeisId) { return false; };
  for (const PeisId target : peersToDial(ids, 12, none)) CHECK(target > 12);
  const auto all = peersToDial(ids, 12, none, true);
  CHECK(std::find(all.begin(), all.end(), 11) != all.end());
  CHECK(peersToDial(ids, 10, [](PeisId) { return true; }).empty());  // all linked already
}

TEST_CASE("link policy: what is pruned", "[unit][link-policy]") {
  std::vector<PeisId> ids;
  for (PeisId id = 100; id < 140; ++id) ids.push_back(id);
  // A pair the overlay wants and one it does not (the lower id first).
  std::optional<std::pair<PeisId, PeisId>> wanted, unwanted;
  for (const PeisId a : ids) {
    for (const PeisId b : ids) {
      if (a >= b) continue;
      auto& slot = overlayWantsSorted(ids, a, b) ? wanted : unwanted;
      if (!slot) slot = std::pair{a, b};
    }
  }
  REQUIRE(wanted);
  REQUIRE(unwanted);
  const auto [self, peer] = *unwanted;
  const PruneQuestion q{peer, true, true, 5s, true};
  CHECK(shouldPrune(ids, self, q));
  CHECK_FALSE(shouldPrune(ids, wanted->first, PruneQuestion{wanted->second, true, true, 5s, true}));
  CHECK_FALSE(shouldPrune(ids, peer, PruneQuestion{self, true, true, 5s, true}));  // the higher id
  auto young = q;
  young.age = 1s;
  CHECK_FALSE(shouldPrune(ids, self, young));
  auto only = q;
  only.alternative = false;  // never cut a PEIS off
  CHECK_FALSE(shouldPrune(ids, self, only));
  auto explicitLink = q;
  explicitLink.discovered = false;
  CHECK_FALSE(shouldPrune(ids, self, explicitLink));
  auto unknown = q;
  unknown.knownByBeacon = false;
  CHECK_FALSE(shouldPrune(ids, self, unknown));
  auto tool = q;
  tool.peerIsTool = true;
  CHECK_FALSE(shouldPrune(ids, self, tool));
}

TEST_CASE("link policy: a link that carries a heavy flow is not pruned until it is idle",
          "[unit][link-policy][demand]") {
  const std::vector<PeisId> ids{100, 200, 300, 400, 500, 600, 700, 800};
  std::optional<std::pair<PeisId, PeisId>> unwanted;
  for (const PeisId a : ids) {
    for (const PeisId b : ids) {
      if (a < b && !unwanted && !overlayWantsSorted(ids, a, b)) unwanted = std::pair{a, b};
    }
  }
  REQUIRE(unwanted);
  const auto [self, peer] = *unwanted;

  DemandConfig config;
  config.bytesPerSecond = 1000;
  config.window = 2000ms;
  config.idleAfter = 10000ms;
  DemandMeter meter(config);
  const auto start = std::chrono::steady_clock::time_point{} + 1h;
  auto at = start;
  auto step = [&](std::uint64_t bytes) {  // one step of 500 ms
    meter.add(peer, bytes);
    at += 500ms;
    meter.tick(at);
  };
  PruneQuestion q{peer, true, true, 5s, true};
  q.busy = meter.busy(peer, at);
  CHECK(shouldPrune(ids, self, q));  // never busy: the overlay's rule alone

  for (int i = 0; i < 4; ++i) step(600);  // 1200 B/s over the window
  REQUIRE(meter.heavy(peer));
  q.busy = meter.busy(peer, at);
  CHECK_FALSE(shouldPrune(ids, self, q));  // it carries the flow

  for (int i = 0; i < 8; ++i) step(0);  // 4 s idle: not heavy, still busy lately
  CHECK_FALSE(meter.heavy(peer));
  q.busy = meter.busy(peer, at);
  CHECK_FALSE(shouldPrune(ids, self, q));
  for (int i = 0; i < 16; ++i) step(0);  // idle for longer than idleAfter
  q.busy = meter.busy(peer, at);
  CHECK(shouldPrune(ids, self, q));  // pruned as the overlay would
}

TEST_CASE("demand meter: a flow is heavy only when sustained over the window",
          "[unit][link-policy][demand]") {
  DemandConfig config;
  config.bytesPerSecond = 1000;
  DemandMeter meter(config);
  auto at = std::chrono::steady_clock::time_point{} + 1h;
  auto step = [&](PeisId peer, std::uint64_t bytes) {
    meter.add(peer, bytes);
    at += 500ms;
    meter.tick(at);
  };
  step(7, 1500);  // one burst of 1500 B in a 2 s window: 750 B/s
  CHECK_FALSE(meter.heavy(7));
  for (int i = 0; i < 3; ++i) step(7, 1500);  // 6000 B in 2 s
  CHECK(meter.heavy(7));
  CHECK(meter.rate(7) == 3000);
  for (int i = 0; i < 4; ++i) step(9, 5000);            // a heavier flow comes first
  CHECK(meter.heavyPeers() == std::vector<PeisId>{9});  // 7 stopped: its window is empty
  meter.add(7, 100000);
  at += 500ms;
  meter.tick(at);
  CHECK(meter.heavyPeers() == std::vector<PeisId>{7, 9});

  // A fast flow is heavy once the window's bytes are there, before a step.
  DemandMeter fresh(config);
  CHECK_FALSE(fresh.add(5, 1999));
  CHECK(fresh.add(5, 1));  // 2000 B: 1000 B/s over 2 s
  CHECK_FALSE(fresh.add(5, 1));
  CHECK(fresh.heavy(5));
  CHECK(fresh.heavyPeers() == std::vector<PeisId>{5});

  DemandConfig off = config;
  off.bytesPerSecond = 0;
  DemandMeter none(off);
  none.add(7, 1u << 30);
  none.tick(at);
  CHECK_FALSE(none.heavy(7));
  CHECK(none.heavyPeers().empty());
}

TEST_CASE("demand links: dial heavy flows over relays, bounded, never for a tool",
          "[unit][link-policy][demand]") {
  DemandConfig config;
  config.maxLinks = 2;
  const std::vector<DemandPeer> heavy{{10, true, false, false, true},    // linked already
                                      {11, false, true, false, true},    // being dialled
                                      {12, false, false, true, true},    // a tool
                                      {13, false, false, false, false},  // no address known
                                      {14, false, false, false, true},
                                      {15, false, false, false, true},
                                      {16, false, false, false, true}};
  CHECK(demandDials(heavy, 0, config, false) == std::vector<PeisId>{14, 15});
  CHECK(demandDials(heavy, 1, config, false) == std::vector<PeisId>{14});
  CHECK(demandDials(heavy, 2, config, false).empty());  // the bound is reached
  CHECK(demandDials(heavy, 0, config, true).empty());   // a tool dials for nobody
  auto off = config;
  off.bytesPerSecond = 0;
  CHECK(demandDials(heavy, 0, off, false).empty());
}
