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
