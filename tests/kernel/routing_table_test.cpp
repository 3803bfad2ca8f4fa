// Unit tests of the routing table (net/routing_table.h) without a network:
// a small simulator delivers the tables' messages over links in rounds (one
// round = one advert delay), and the tests check convergence to the shortest
// paths, that a crashed PEIS leaves every table within one liveness period
// without counting to infinity, that a PEIS that leaves cleanly vanishes at
// once, that a pruned link or a healed partition re-converges, and what a
// tool PEIS advertises.
#include "net/routing_table.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <deque>
#include <map>
#include <memory>
#include <queue>
#include <random>
#include <set>

using peis::PeisId;
using peis::net::RoutingTable;
namespace wire = peis::wire;
using namespace std::chrono_literals;

namespace {

constexpr auto kRound = 100ms;  // the advert delay
constexpr auto kHoldFor = 1000ms;

class Ecology {
 public:
  using Time = RoutingTable::Time;

  void add(PeisId id, bool tool = false, std::uint64_t incarnation = 1) {
    RoutingTable::Config config;
    config.self = id;
    config.incarnation = incarnation;
    config.name = "p" + std::to_string(id);
    config.tool = tool;
    config.holdFor = kHoldFor;
    nodes_[id] = std::make_unique<RoutingTable>(config);
    hellos_[id] = wire::Hello{wire::kVersion,
                              "eco",
                              id,
                              incarnation,
                              config.name,
                              0,
                              tool ? wire::kCapabilityTool : 0u,
                              ""};
  }

  void link(PeisId a, PeisId b) {
    links_.insert({std::min(a, b), std::max(a, b)});
    handshake(a, b);
  }

  // The link replaced by a new one to the same PEIS (a duplicate link: both
  // ends keep the one the lower id dialled). What was in flight on the old
  // link is lost; the new link's first adverts are the whole tables.
  void relink(PeisId a, PeisId b) {
    std::erase_if(inFlight_, [&](const InFlight& m) {
      return (m.from == a && m.to == b) || (m.from == b && m.to == a);
    });
    handshake(a, b);
  }

  // Both ends take the other's Hello, and each sends its whole table.
  void handshake(PeisId a, PeisId b) {
    nodes_.at(a)->linkUp(hellos_.at(b));
    nodes_.at(b)->linkUp(hellos_.at(a));
    recompute(a);
    recompute(b);
    send(a, b, nodes_.at(a)->fullAdvert(b));
    send(b, a, nodes_.at(b)->fullAdvert(a));
  }

  void unlink(PeisId a, PeisId b) {
    links_.erase({std::min(a, b), std::max(a, b)});
    if (nodes_.count(a)) nodes_.at(a)->linkDown(b), recompute(a);
    if (nodes_.count(b)) nodes_.at(b)->linkDown(a), recompute(b);
  }

  // Killed: its links close with nothing said.
  void crash(PeisId id) {
    for (const auto n : neighbours(id)) unlink(id, n);
    nodes_.erase(id);
  }

  // Quits cleanly: a Leave on each link, then the links close.
  void leave(PeisId id) {
    const auto neighbours = this->neighbours(id);
    for (const auto n : neighbours) {
      send(id, n, wire::Leave{id, hellos_.at(id).incarnation});
    }
    step();  // the Leave frames arrive before the links close
    for (const auto n : neighbours) unlink(id, n);
    nodes_.erase(id);
  }

  // One round: every message in flight arrives, then every table
  // recomputes and sends what it has to say.
  void step() {
    now_ += kRound;
    auto inFlight = std::move(inFlight_);
    inFlight_.clear();
    for (auto& m : inFlight) deliver(m);
    for (const auto& [id, node] : nodes_) recompute(id);
    for (const auto& [id, node] : nodes_) {
      for (auto& [to, routes] : node->advertise()) send(id, to, routes);
    }
  }

  void run(int rounds) {
    for (int i = 0; i < rounds; ++i) step();
  }

  // Rounds until `done` holds, at most `most`; -1 if it never does.
  template <typename F>
  int roundsUntil(F done, int most = 200) {
    for (int i = 0; i <= most; ++i) {
      if (done()) return i;
      step();
    }
    return -1;
  }

  RoutingTable& at(PeisId id) { return *nodes_.at(id); }
  bool has(PeisId at, PeisId id) const { return nodes_.at(at)->find(id) != nullptr; }
  int hops(PeisId at, PeisId id) const {
    const auto* r = nodes_.at(at)->find(id);
    return r ? r->hops : -1;
  }
  // The most hops any table has shown for `id` since watching began.
  int mostHopsSeen(PeisId id) const {
    const auto it = mostHops_.find(id);
    return it == mostHops_.end() ? -1 : it->second;
  }
  void watch(PeisId id) { mostHops_[id] = 0; }
  int downEvents(PeisId at, PeisId id) const { return downs_.count({at, id}); }
  std::vector<PeisId> ids() const {
    std::vector<PeisId> all;
    for (const auto& [id, node] : nodes_) all.push_back(id);
    return all;
  }

  // Shortest-path hop counts from `from` over the links (BFS).
  std::map<PeisId, int> distances(PeisId from) const {
    std::map<PeisId, int> d{{from, 0}};
    std::queue<PeisId> frontier;
    frontier.push(from);
    while (!frontier.empty()) {
      const auto at = frontier.front();
      frontier.pop();
      for (const auto n : neighbours(at)) {
        if (d.emplace(n, d[at] + 1).second) frontier.push(n);
      }
    }
    return d;
  }

  // Every table holds exactly the PEIS its component holds, at BFS hops.
  bool converged() const {
    for (const auto& [id, node] : nodes_) {
      const auto d = distances(id);
      if (node->routes().size() != d.size()) return false;
      for (const auto& [other, hops] : d) {
        const auto* r = node->find(other);
        if (!r || r->hops != hops || r->held) return false;
      }
    }
    return true;
  }

  // Every table, for the message of a failed check.
  std::string describe() const {
    std::string text;
    for (const auto& [id, node] : nodes_) {
      text += std::to_string(id) + " (seqno " + std::to_string(node->ownSeqno()) + "):";
      for (const auto& [other, r] : node->routes()) {
        text += " " + std::to_string(other) + "@" + std::to_string(r.hops) + "/" +
                std::to_string(r.nextHop) + "#" + std::to_string(r.seqno) + (r.held ? "h" : "");
      }
      text += "\n";
    }
    return text;
  }

  std::vector<PeisId> neighbours(PeisId id) const {
    std::vector<PeisId> result;
    for (const auto& [a, b] : links_) {
      if (a == id) result.push_back(b);
      if (b == id) result.push_back(a);
    }
    return result;
  }

 private:
  struct InFlight {
    PeisId from, to;
    wire::LinkMessage message;
  };

  void send(PeisId from, PeisId to, wire::LinkMessage message) {
    if (auto* routes = std::get_if<wire::Routes>(&message); routes && routes->entries.empty()) {
      return;
    }
    inFlight_.push_back(InFlight{from, to, std::move(message)});
  }

  void deliver(InFlight& m) {
    if (!links_.count({std::min(m.from, m.to), std::max(m.from, m.to)})) return;  // link gone
    if (!nodes_.count(m.to)) return;
    auto& node = *nodes_.at(m.to);
    if (auto* routes = std::get_if<wire::Routes>(&m.message)) {
      node.onRoutes(m.from, routes->entries);
    } else if (auto* leave = std::get_if<wire::Leave>(&m.message)) {
      if (node.onLeave(m.from, *leave, now_)) {
        for (const auto n : neighbours(m.to)) {
          if (n != m.from) send(m.to, n, *leave);
        }
        recompute(m.to);
      }
    } else if (auto* request = std::get_if<wire::SeqnoRequest>(&m.message)) {
      node.onSeqnoRequest(m.from, *request, now_);
    }
  }

  void recompute(PeisId id) {
    auto& node = *nodes_.at(id);
    const auto changes = node.recompute(now_);
    for (const auto down : changes.down) downs_.insert({id, down});
    for (auto& m : node.takeMessages()) send(id, m.to, std::move(m.message));
    for (auto& [watched, most] : mostHops_) {
      if (const auto* r = node.find(watched)) most = std::max(most, r->hops);
    }
  }

  Time now_{};
  std::map<PeisId, std::unique_ptr<RoutingTable>> nodes_;
  std::map<PeisId, wire::Hello> hellos_;
  std::set<std::pair<PeisId, PeisId>> links_;
  std::deque<InFlight> inFlight_;
  std::map<PeisId, int> mostHops_;
  std::multiset<std::pair<PeisId, PeisId>> downs_;
};

// One liveness period, in rounds: the time a departed PEIS may linger.
constexpr int kLivenessRounds = 2 * static_cast<int>(kHoldFor / kRound);

bool goneEverywhere(Ecology& e, PeisId id) {
  for (const auto at : e.ids()) {
    if (e.has(at, id)) return false;
  }
  return true;
}

// A connected random graph: a random spanning tree plus extra links (loops).
void randomEcology(Ecology& e, std::mt19937& random, int n, int extraLinks) {
  std::vector<PeisId> ids;
  for (int i = 0; i < n; ++i) {
    ids.push_back(1000 + 7 * i);
    e.add(ids.back());
  }
  for (int i = 1; i < n; ++i) {
    e.link(ids[static_cast<std::size_t>(i)], ids[std::uniform_int_distribution<std::size_t>(
                                                 0, static_cast<std::size_t>(i - 1))(random)]);
  }
  for (int k = 0; k < extraLinks; ++k) {
    std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
    const auto a = ids[pick(random)], b = ids[pick(random)];
    const auto n = e.neighbours(a);
    if (a != b && std::find(n.begin(), n.end(), b) == n.end()) e.link(a, b);
  }
}

}  // namespace

TEST_CASE("routing: tables converge to the shortest paths", "[unit][routing]") {
  Ecology e;
  for (PeisId id : {1, 2, 3, 4, 5}) e.add(id);
  e.link(1, 2);
  e.link(2, 3);
  e.link(3, 4);
  e.link(4, 5);
  CHECK(e.roundsUntil([&] { return e.converged(); }) >= 0);
  CHECK(e.hops(1, 5) == 4);
  CHECK(e.at(1).nextHop(5) == 2);
  CHECK(e.at(1).nextHop(1) == 0);  // this PEIS: no next hop
  e.link(1, 5);                    // a ring: the short way round wins
  CHECK(e.roundsUntil([&] { return e.converged(); }) >= 0);
  CHECK(e.hops(1, 4) == 2);
  CHECK(e.at(1).nextHop(4) == 5);
}

TEST_CASE("routing: a crashed PEIS leaves every table within a liveness period, no counting",
          "[unit][routing]") {
  SECTION("a triangle with a PEIS hanging off one corner (the classic loop)") {
    Ecology e;
    for (PeisId id : {10, 20, 30, 40}) e.add(id);
    e.link(10, 20);
    e.link(20, 30);
    e.link(30, 10);
    e.link(10, 40);  // 40 hangs off 10
    REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
    e.watch(40);
    e.crash(40);
    const int rounds = e.roundsUntil([&] { return goneEverywhere(e, 40); });
    CHECK(rounds >= 0);
    CHECK(rounds <= kLivenessRounds);
    // Before the fix the others bounced 40 between them, up to 32 hops.
    CHECK(e.mostHopsSeen(40) <= 3);
    CHECK(e.roundsUntil([&] { return e.converged(); }) >= 0);
  }
  SECTION("random ecologies with loops: every PEIS crashed in turn") {
    std::mt19937 random(20261123);
    for (int trial = 0; trial < 12; ++trial) {
      Ecology e;
      randomEcology(e, random, 14, 10);
      REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
      const auto ids = e.ids();
      const auto victim = ids[static_cast<std::size_t>(trial) % ids.size()];
      int farthest = 0;
      for (const auto at : ids) farthest = std::max(farthest, e.hops(at, victim));
      e.watch(victim);
      e.crash(victim);
      INFO("trial " << trial << ", PEIS " << victim << " crashed");
      const int rounds = e.roundsUntil([&] { return goneEverywhere(e, victim); });
      CHECK(rounds >= 0);
      CHECK(rounds <= kLivenessRounds);
      CHECK(e.mostHopsSeen(victim) <= farthest + 2);
      // The rest (maybe split in parts) converges again.
      CHECK(e.roundsUntil([&] { return e.converged(); }) >= 0);
    }
  }
}

TEST_CASE("routing: a PEIS that leaves cleanly vanishes at once", "[unit][routing]") {
  Ecology e;
  for (PeisId id : {10, 20, 30, 40, 50}) e.add(id);
  e.link(10, 20);
  e.link(20, 30);
  e.link(30, 40);
  e.link(40, 10);
  e.link(30, 50);  // 50 leaves; 10 is 3 hops from it
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  e.watch(50);
  e.leave(50);
  // The Leave floods one link a round: gone within the diameter, not after
  // a hold time, and nobody ever held or lengthened a route to it.
  CHECK(e.roundsUntil([&] { return goneEverywhere(e, 50); }) <= 3);
  CHECK(e.mostHopsSeen(50) <= 3);
  // Stale adverts of it are refused from then on...
  std::vector<wire::RouteEntry> stale{{50, 2, 0, 1, 0, "p50"}};
  e.at(10).onRoutes(20, stale);
  e.run(3);
  CHECK_FALSE(e.has(10, 50));
  // ...but a new life of it is welcome.
  e.add(50, false, 2);
  e.link(30, 50);
  CHECK(e.roundsUntil([&] { return e.converged(); }) >= 0);
  CHECK(e.at(10).find(50)->incarnation == 2);
}

TEST_CASE("routing: a pruned link with another way round keeps the route up", "[unit][routing]") {
  Ecology e;
  for (PeisId id : {1, 2, 3, 4}) e.add(id);
  e.link(1, 2);
  e.link(2, 3);
  e.link(3, 4);
  e.link(4, 1);
  e.link(1, 3);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  e.unlink(1, 3);  // 1 and 3 still reach each other through 2 and 4
  // Every offer 1 has for 3 now is infeasible (2 hops against the 1 it had):
  // 1 holds the route and asks 3 for a new seqno, which comes round.
  CHECK(e.has(1, 3));
  CHECK(e.at(1).find(3)->held);
  const auto before = e.at(3).ownSeqno();
  CHECK(e.roundsUntil([&] { return e.converged(); }, 8) >= 0);
  CHECK(e.at(3).ownSeqno() > before);
  CHECK(e.hops(1, 3) == 2);
  CHECK(e.downEvents(1, 3) == 0);
  CHECK(e.downEvents(3, 1) == 0);
}

TEST_CASE("routing: a replaced link keeps the routes through it up", "[unit][routing]") {
  // 1 - 2 - 3: the link 2 - 3 is replaced by a duplicate. 1 stays reachable
  // from 3 all along (it went down and up again, failing the writes in
  // flight to it with "went away", before the new link's adverts came).
  Ecology e;
  for (PeisId id : {1, 2, 3}) e.add(id);
  e.link(1, 2);
  e.link(2, 3);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  e.relink(2, 3);
  CHECK(e.has(3, 1));
  CHECK(e.has(1, 3));
  INFO(e.describe());
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  CHECK(e.downEvents(3, 1) == 0);
  CHECK(e.downEvents(1, 3) == 0);
}

TEST_CASE("routing: a route withdrawn while its link was replaced is gone with the new advert",
          "[unit][routing]") {
  // 3 - 2 - 4: 4 crashes and the link 2 - 3 is replaced before 2 tells 3;
  // the new link's whole table, without 4, takes 4 out of 3's table.
  Ecology e;
  for (PeisId id : {2, 3, 4}) e.add(id);
  e.link(2, 3);
  e.link(2, 4);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  e.crash(4);
  e.relink(2, 3);
  CHECK(e.has(3, 4));  // the old link's advert stands until the whole table comes
  INFO(e.describe());
  CHECK(e.roundsUntil([&] { return !e.has(3, 4); }) == 1);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
}

TEST_CASE("routing: a healed partition converges again", "[unit][routing]") {
  Ecology e;
  for (PeisId id : {1, 2, 3, 4, 5, 6}) e.add(id);
  e.link(1, 2);
  e.link(2, 3);
  e.link(3, 1);
  e.link(4, 5);
  e.link(5, 6);
  e.link(6, 4);
  e.link(3, 4);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  e.unlink(3, 4);
  const int rounds = e.roundsUntil([&] { return e.converged(); });  // two islands
  CHECK(rounds >= 0);
  CHECK(rounds <= kLivenessRounds);
  CHECK_FALSE(e.has(1, 6));
  e.link(2, 5);  // healed elsewhere: the old seqnos are no hindrance
  const bool healed = e.roundsUntil([&] { return e.converged(); }) >= 0;
  INFO(e.describe());
  CHECK(healed);
  CHECK(e.hops(1, 6) == 3);
}

TEST_CASE("routing: split horizon, the hop limit and id collisions", "[unit][routing]") {
  Ecology e;
  for (PeisId id : {1, 2}) e.add(id);
  e.link(1, 2);
  REQUIRE(e.roundsUntil([&] { return e.converged(); }) >= 0);
  // 2 never tells 1 a route that goes through 1.
  std::vector<wire::RouteEntry> via{{9, 3, 0, 5, 0, "p9"}};
  e.at(2).onRoutes(1, via);
  e.at(2).recompute({});
  for (const auto& entry : e.at(2).fullAdvert(1).entries) CHECK(entry.id != 9);
  // A route longer than 32 hops is ignored.
  std::vector<wire::RouteEntry> far{{8, 32, 0, 5, 0, "p8"}};
  e.at(2).onRoutes(1, far);
  e.at(2).recompute({});
  CHECK_FALSE(e.has(2, 8));
  // Our own id at 0 hops with another incarnation: a collision.
  std::vector<wire::RouteEntry> mine{{2, 0, 0, 77, 0, "other"}};
  e.at(2).onRoutes(1, mine);
  CHECK(e.at(2).takeCollision() == std::optional<std::uint64_t>(77));
  CHECK_FALSE(e.at(2).takeCollision());
}

TEST_CASE("routing: a tool PEIS is marked and relays for nobody", "[unit][routing]") {
  Ecology e;
  e.add(1);
  e.add(2, true);  // a tool between 1 and 3
  e.add(3);
  e.link(1, 2);
  e.link(2, 3);
  e.run(10);
  REQUIRE(e.has(1, 2));
  CHECK(e.at(1).find(2)->tool);  // from its Hello
  CHECK_FALSE(e.has(1, 3));      // the tool advertises only itself
  e.add(4);
  e.link(3, 4);
  e.run(10);
  REQUIRE(e.has(4, 2));
  CHECK(e.at(4).find(2)->tool);  // from the route entry's flag, two hops away
  CHECK_FALSE(e.at(4).find(3)->tool);
}

// Issue 13: what a hostile neighbour can make a routing table do.
namespace {

RoutingTable tableOf(PeisId self, std::size_t maxRoutes = 4096) {
  RoutingTable::Config config;
  config.self = self;
  config.incarnation = 1;
  config.name = "p" + std::to_string(self);
  config.maxRoutes = maxRoutes;
  return RoutingTable(config);
}

wire::Hello helloOf(PeisId id, std::uint64_t incarnation = 1) {
  return wire::Hello{wire::kVersion, "eco", id, incarnation, "p" + std::to_string(id), 0, 0u, ""};
}

}  // namespace

TEST_CASE("routing: a big advert is merged as if applied entry by entry", "[unit][routing]") {
  std::mt19937 random(13);
  for (int round = 0; round < 20; ++round) {
    auto merged = tableOf(1), oneByOne = tableOf(1);
    for (auto* t : {&merged, &oneByOne}) t->linkUp(helloOf(2));
    std::vector<wire::RouteEntry> advert;
    for (int i = 0; i < 300; ++i) {
      const PeisId id = 10 + static_cast<PeisId>(random() % 200);  // repeats, any order
      const auto hops = static_cast<std::uint8_t>(random() % 4 == 0 ? 255 : 1 + random() % 5);
      advert.push_back(wire::RouteEntry{id, hops, 0, 1, static_cast<std::uint32_t>(i), "x"});
    }
    auto copy = advert;
    merged.onRoutes(2, copy);  // over the merge threshold: one sorted merge
    for (const auto& entry : advert) {
      std::vector<wire::RouteEntry> one{entry};
      oneByOne.onRoutes(2, one);
    }
    merged.recompute({});
    oneByOne.recompute({});
    CHECK(merged.routes() == oneByOne.routes());
  }
}

TEST_CASE("routing: tables and adverts are bounded by maxRoutes", "[unit][routing]") {
  auto table = tableOf(1, 100);
  table.linkUp(helloOf(2));
  table.linkUp(helloOf(3));
  std::vector<wire::RouteEntry> flood;
  for (PeisId id = 2000000000; flood.size() < 65534; --id) {  // descending, as the attack
    flood.push_back(wire::RouteEntry{id, 1, 0, 7, 1, "f"});
  }
  table.onRoutes(2, flood);
  table.recompute({});
  CHECK(table.routes().size() <= 101);
  CHECK(table.refused() >= 65534 - 100);
  // The linked PEIS stay in however full the table is.
  CHECK(table.contains(2));
  CHECK(table.contains(3));
  // What it tells a neighbour is bounded too.
  CHECK(table.fullAdvert(3).entries.size() <= 101);
}

TEST_CASE("routing: a linked PEIS's route and life are its own link's", "[unit][routing]") {
  auto table = tableOf(1);
  table.linkUp(helloOf(2, 50));  // linked, incarnation 50
  table.linkUp(helloOf(3));      // the hostile neighbour
  table.recompute({});
  // 3 offers 2 as a "newer life" with a high seqno, then says it left.
  std::vector<wire::RouteEntry> lie{{2, 1, 0, 51, 1000, "p2"}};
  table.onRoutes(3, lie);
  table.recompute({});
  CHECK(table.find(2)->nextHop == 2);
  CHECK(table.find(2)->incarnation == 50);
  CHECK_FALSE(table.onLeave(3, wire::Leave{2, 50}, {}));
  table.recompute({});
  CHECK(table.contains(2));
  // 2 itself may say so.
  CHECK(table.onLeave(2, wire::Leave{2, 50}, {}));
  // A Leave of a PEIS nobody offers is not remembered (nor passed on).
  CHECK_FALSE(table.onLeave(3, wire::Leave{424242, 1}, {}));
}

TEST_CASE("routing: a departed PEIS's last frames are taken for a while over its ways",
          "[unit][routing]") {
  auto table = tableOf(1);
  for (PeisId n : {2, 3, 4}) table.linkUp(helloOf(n));
  std::vector<wire::RouteEntry> viaTwo{{9, 1, 0, 5, 1, "p9"}};
  table.onRoutes(2, viaTwo);
  const auto now = RoutingTable::Time{} + 10s;
  table.recompute(now);
  REQUIRE(table.find(9)->nextHop == 2);
  CHECK_FALSE(table.sentBeforeLeaving(2, 9, now, 2s));  // it has not left
  // Its Leave comes over 3 (a flood is faster there); its last frame over 2.
  REQUIRE(table.onLeave(3, wire::Leave{9, 5}, now));
  table.recompute(now);
  CHECK_FALSE(table.contains(9));
  CHECK(table.sentBeforeLeaving(2, 9, now + 1s, 2s));
  CHECK_FALSE(table.sentBeforeLeaving(4, 9, now + 1s, 2s));  // never a way of its frames
  CHECK_FALSE(table.sentBeforeLeaving(2, 9, now + 2s, 2s));  // the grace is over
  CHECK_FALSE(table.sentBeforeLeaving(2, 8, now, 2s));       // never heard of
}

TEST_CASE("routing: who may relay a source's frames", "[unit][routing]") {
  auto table = tableOf(1);
  for (PeisId n : {2, 3, 4}) table.linkUp(helloOf(n));
  std::vector<wire::RouteEntry> viaTwo{{9, 1, 0, 1, 1, "p9"}};
  std::vector<wire::RouteEntry> viaThree{{9, 1, 0, 1, 1, "p9"}};
  std::vector<wire::RouteEntry> farFour{{9, 3, 0, 1, 1, "p9"}};
  table.onRoutes(2, viaTwo);
  table.onRoutes(3, viaThree);
  table.onRoutes(4, farFour);
  const auto now = RoutingTable::Time{} + 10s;
  table.recompute(now);
  REQUIRE(table.find(9)->hops == 2);
  CHECK(table.mayRelay(table.find(9)->nextHop, 9, now, 2s));
  CHECK(table.mayRelay(2, 9, now, 2s));  // an equal route (asymmetric paths)
  CHECK(table.mayRelay(3, 9, now, 2s));
  CHECK_FALSE(table.mayRelay(4, 9, now, 2s));  // a longer one: not a way 9's frames come
  // A linked PEIS's frames come over its own link only.
  CHECK_FALSE(table.mayRelay(3, 2, now, 2s));
  // An unknown source: held until its route comes, then asked again.
  CHECK(table.mayRelay(4, 77, now, 2s));
  // A PEIS that links just after sending through 3 (which offers it): its
  // frames relayed by 3 are taken for 2 s after the link came up, and only
  // from a neighbour offering a route to it.
  std::vector<wire::RouteEntry> threeOffersFive{{9, 1, 0, 1, 1, "p9"}, {5, 1, 0, 1, 1, "p5"}};
  table.onRoutes(3, threeOffersFive);
  const auto linked = now + 1s;
  table.linkUp(helloOf(5));
  table.recompute(linked);
  REQUIRE(table.find(5)->nextHop == 5);
  CHECK(table.mayRelay(3, 5, linked + 1s, 2s));
  CHECK_FALSE(table.mayRelay(4, 5, linked + 1s, 2s));
  CHECK_FALSE(table.mayRelay(3, 5, linked + 3s, 2s));
}

TEST_CASE("routing: a relay tells its next hop the route to a source as it is now",
          "[unit][routing]") {
  auto table = tableOf(1);
  for (PeisId n : {2, 3}) table.linkUp(helloOf(n));
  std::vector<wire::RouteEntry> farNine{{9, 2, 0, 1, 1, "p9"}};
  table.onRoutes(3, farNine);
  const auto now = RoutingTable::Time{} + 10s;
  table.recompute(now);
  REQUIRE(table.find(9)->hops == 3);
  table.fullAdvert(2);
  CHECK_FALSE(table.tellNow(2, 9));  // told with the full advert
  // 9 links to us: 2 was told a route of 3 hops, and would take 9's frames
  // relayed by us for spoofed until it hears of the shorter one.
  table.linkUp(helloOf(9));
  table.recompute(now + 1s);
  const auto told = table.tellNow(2, 9);
  REQUIRE(told);
  REQUIRE(told->entries.size() == 1);
  CHECK(told->entries[0].hops == 1);
  CHECK_FALSE(table.tellNow(2, 9));
}

TEST_CASE("routing: a seqno request far above its own seqno is made up", "[unit][routing]") {
  auto table = tableOf(1);
  table.linkUp(helloOf(2));
  table.onSeqnoRequest(2, wire::SeqnoRequest{1, 1, 0xffffffff, 5}, {});
  CHECK(table.ownSeqno() == 0);
  table.onSeqnoRequest(2, wire::SeqnoRequest{1, 1, 1, 5}, {});
  CHECK(table.ownSeqno() == 1);
}
