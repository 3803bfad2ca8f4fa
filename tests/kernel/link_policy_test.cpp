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
