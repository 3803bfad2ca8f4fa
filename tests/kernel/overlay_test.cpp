// Unit tests of the discovery beacon codec and of the overlay (which pairs
// of PEIS keep a link): connectivity, few links each, short paths, and few
// link changes when a PEIS joins.
#include "net/overlay.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <queue>
#include <random>
#include <set>

#include "net/beacon.h"

using peis::PeisId;
using namespace peis::net;

namespace {

using Edges = std::set<std::pair<PeisId, PeisId>>;

Edges wantedPairs(const std::vector<PeisId>& ids) {
  Edges edges;
  for (PeisId a : ids) {
    for (PeisId f : fingers(ids, a)) edges.insert({std::min(a, f), std::max(a, f)});
  }
  return edges;
}

// Largest BFS distance from `start`, or -1 if some id is unreachable.
int eccentricity(const std::vector<PeisId>& ids, const Edges& edges, PeisId start) {
  std::map<PeisId, std::vector<PeisId>> adjacent;
  for (const auto& [a, b] : edges) {
    adjacent[a].push_back(b);
    adjacent[b].push_back(a);
  }
  std::map<PeisId, int> distance{{start, 0}};
  std::queue<PeisId> frontier;
  frontier.push(start);
  while (!frontier.empty()) {
    const auto at = frontier.front();
    frontier.pop();
    for (PeisId next : adjacent[at]) {
      if (distance.emplace(next, distance[at] + 1).second) frontier.push(next);
    }
  }
  if (distance.size() != ids.size()) return -1;
  int most = 0;
  for (const auto& [id, d] : distance) most = std::max(most, d);
  return most;
}

std::vector<PeisId> randomIds(std::mt19937& random, std::size_t n) {
  std::uniform_int_distribution<PeisId> pick(1, peis::kMaxPeisId);
  std::set<PeisId> ids;
  while (ids.size() < n) ids.insert(pick(random));
  return {ids.begin(), ids.end()};
}

}  // namespace

TEST_CASE("beacons round-trip and every malformed beacon is rejected", "[unit][overlay]") {
  const Beacon beacon{"home", 6890, 1234567890123ull, 40123, true};
  const auto bytes = encodeBeacon(beacon);
  REQUIRE(decodeBeacon(bytes) == beacon);
  const Beacon tool{"home", 6891, 5, 40124, false, true};  // flags bit 1: a tool PEIS
  REQUIRE(decodeBeacon(encodeBeacon(tool)) == tool);
  const Beacon secured{"home", 6892, 5, 40125, false, false, true};  // bit 2: a secured ecology
  REQUIRE(decodeBeacon(encodeBeacon(secured)) == secured);
  CHECK(bytes.size() == 4 + 2 + 1 + 4 + 4 + 8 + 2 + 1);
  CHECK(bytes.substr(0, 4) == "PEIB");

  for (std::size_t n = 0; n < bytes.size(); ++n) {
    INFO("truncated to " << n << " bytes");
    CHECK_FALSE(decodeBeacon(bytes.substr(0, n)));
  }
  CHECK_FALSE(decodeBeacon(bytes + "x"));  // trailing byte
  auto corrupt = [&](std::size_t at, char value) {
    auto copy = bytes;
    copy[at] = value;
    return decodeBeacon(copy);
  };
  CHECK_FALSE(corrupt(0, 'X'));               // magic
  CHECK_FALSE(corrupt(5, 1));                 // version 1 (the protocol is version 3)
  CHECK_FALSE(corrupt(11, '\x80'));           // id becomes negative
  CHECK_FALSE(corrupt(bytes.size() - 1, 8));  // flags > 7
  auto noPort = beacon;
  noPort.port = 0;
  CHECK_FALSE(decodeBeacon(encodeBeacon(noPort)));
  auto noEcology = beacon;
  noEcology.ecology.clear();
  CHECK_FALSE(decodeBeacon(encodeBeacon(noEcology)));
}

TEST_CASE("fingers are the nearest PEIS in each power-of-two id distance", "[unit][overlay]") {
  const std::vector<PeisId> ids{10, 11, 12, 13, 14, 17, 30, 100};
  // From 10: distance 1 -> 11, [2,4) -> 12, [4,8) -> 14, [16,32) -> 30, [64,128) -> 100.
  CHECK(fingers(ids, 10) == std::vector<PeisId>{11, 12, 14, 30, 100});
  // From 100 the ring wraps: 10 is 2^31 - 90 away, in [2^30, 2^31).
  CHECK(fingers(ids, 100) == std::vector<PeisId>{10});
  CHECK(overlayWants(ids, 100, 10));
  CHECK(overlayWants(ids, 10, 100));
  CHECK(fingers({5}, 5).empty());
}

TEST_CASE("the overlay is connected with few links and short paths", "[unit][overlay]") {
  std::mt19937 random(42);
  for (std::size_t n : {2u, 3u, 5u, 10u, 50u, 200u, 500u}) {
    for (int round = 0; round < 3; ++round) {
      auto ids = round == 0 ? std::vector<PeisId>() : randomIds(random, n);
      if (round == 0) {
        for (std::size_t i = 0; i < n; ++i) ids.push_back(static_cast<PeisId>(1001 + i));
      }
      INFO("n = " << n << ", round " << round);
      const auto edges = wantedPairs(ids);
      const double logN = std::log2(static_cast<double>(n));
      // Connected, and no PEIS much further than log N hops.
      const int hops = eccentricity(ids, edges, ids[n / 2]);
      REQUIRE(hops >= 0);
      CHECK(hops <= 2 * static_cast<int>(std::ceil(logN)) + 2);
      // O(log N) links on average (each pair counted once).
      CHECK(static_cast<double>(edges.size()) / static_cast<double>(n) <= 2 * logN + 2);
      for (const auto& [a, b] : edges) CHECK(overlayWants(ids, a, b));
    }
  }
}

TEST_CASE("a joining PEIS changes few wanted links", "[unit][overlay]") {
  std::mt19937 random(7);
  auto ids = randomIds(random, 200);
  const auto before = wantedPairs(ids);
  std::uniform_int_distribution<PeisId> pick(1, peis::kMaxPeisId);
  for (int join = 0; join < 20; ++join) {
    auto grown = ids;
    grown.push_back(pick(random));
    const auto after = wantedPairs(grown);
    std::size_t lost = 0;
    for (const auto& pair : before) lost += after.count(pair) == 0 ? 1 : 0;
    INFO("join " << join << " dropped " << lost << " of " << before.size() << " links");
    // A join moves O(log^2 N) fingers at most; with positions in the sorted
    // id list instead, about half of all links would move.
    CHECK(lost * 20 <= before.size());
  }
}

TEST_CASE("the sorted overlay test and overlayPeers agree with the fingers", "[unit][overlay]") {
  std::mt19937 random(11);
  for (std::size_t n : {1u, 2u, 3u, 10u, 60u, 200u}) {
    for (int round = 0; round < 3; ++round) {
      std::vector<PeisId> ids;
      if (round == 0) {
        for (std::size_t i = 0; i < n; ++i) ids.push_back(static_cast<PeisId>(1000 + i));
      } else if (round == 1) {
        ids = randomIds(random, n);
      } else {  // both ends of the ring
        for (std::size_t i = 0; i < n; ++i) {
          ids.push_back(static_cast<PeisId>(i % 2 ? 1 + i : peis::kMaxPeisId - i));
        }
        std::sort(ids.begin(), ids.end());
      }
      INFO("n = " << n << ", round " << round);
      for (const PeisId a : ids) {
        std::vector<PeisId> wanted;
        for (const PeisId b : ids) {
          const bool brute = a != b && overlayWants(ids, a, b);
          CHECK(overlayWantsSorted(ids, a, b) == brute);
          if (brute) wanted.push_back(b);
        }
        CHECK(overlayPeers(ids, a) == wanted);
      }
    }
  }
}
