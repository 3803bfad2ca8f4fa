// RoutingTable: distance-vector routing of one PEIS as a pure table, with no
// sockets and no timers (docs/protocol.md §8). It is told which PEIS are
// linked and what each linked PEIS advertises, and answers with the route to
// every reachable PEIS (hops, next hop, incarnation, name), the PEIS that
// became reachable or unreachable, and the `Routes` messages each neighbour
// must be sent (deltas: what changed since it was last told, with split
// horizon). Unit-tested on its own (tests/kernel/routing_table_test.cpp).
#pragma once

#include <boost/container/flat_map.hpp>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "net/wire.h"

namespace peis::net {

class RoutingTable {
 public:
  static constexpr int kMaxHops = 32;
  static constexpr std::uint8_t kWithdrawn = 255;  // a route entry that is no longer valid

  struct Route {
    int hops = 0;  // 0: this PEIS
    PeisId nextHop = 0;
    std::uint64_t incarnation = 0;
    std::string name;
    bool operator==(const Route&) const = default;
  };
  // What one recompute changed (for the Network's events).
  struct Changes {
    std::vector<PeisId> down;  // left the table
    std::vector<PeisId> up;    // entered it, or came back with a new incarnation
    bool changed = false;      // any route moved (hops, next hop, name, …)
  };

  RoutingTable(PeisId self, std::uint64_t incarnation, std::string name);

  PeisId self() const { return self_; }
  // This PEIS took a new id: every route and advert is forgotten.
  void reset(PeisId newSelf);

  // --- Inputs ------------------------------------------------------------------
  // A link to `peer` was established (its Hello).
  void linkUp(const wire::Hello& peer);
  // The last link to `peer` closed.
  void linkDown(PeisId peer);
  // A `Routes` message from linked PEIS `from` (applied as a delta). True
  // when a recompute has work (or a collision was seen).
  bool onRoutes(PeisId from, std::vector<wire::RouteEntry>& entries);
  // Another PEIS advertised our id at 0 hops with this incarnation: an id
  // collision (docs/protocol.md §7). Cleared when taken.
  std::optional<std::uint64_t> takeCollision();
  bool hasWork() const { return !dirty_.empty() || collision_ != 0; }

  // Re-evaluates the routes whose candidates changed.
  Changes recompute();

  // --- Outputs: adverts ------------------------------------------------------------
  // The whole table for a new neighbour (less the routes through it); from
  // then on it gets deltas.
  wire::Routes fullAdvert(PeisId neighbour);
  // The deltas each neighbour needs since its last advert.
  std::vector<std::pair<PeisId, wire::Routes>> advertise();
  // Our route to `id` for `neighbour` now, if it has had its full advert,
  // was not told one yet and the route does not go through it (a relayed
  // frame must not arrive before the route to its source, §8).
  std::optional<wire::Routes> tellNow(PeisId neighbour, PeisId id);

  // --- Queries ---------------------------------------------------------------------
  const Route* find(PeisId id) const;
  bool contains(PeisId id) const { return routes_.count(id) != 0; }
  // The linked PEIS to send through, or 0 (no route, or this PEIS).
  PeisId nextHop(PeisId id) const;
  // Whether linked PEIS `neighbour` advertises a route to `id`.
  bool advertises(PeisId neighbour, PeisId id) const;
  // Whether a linked PEIS other than `peer` advertises a route to it.
  bool hasAlternative(PeisId peer) const;
  const std::map<PeisId, Route>& routes() const { return routes_; }

 private:
  // What a neighbour last heard from us about one route (for deltas).
  struct Told {
    std::uint64_t incarnation = 0;
    std::size_t nameHash = 0;
    int hops = 0;
    static std::size_t hash(const std::string& name) { return std::hash<std::string>{}(name); }
    static Told of(const wire::RouteEntry& e) { return {e.incarnation, hash(e.name), e.hops}; }
  };
  struct Neighbour {
    wire::Hello hello;
    // What it told us it can reach (applied as deltas).
    boost::container::flat_map<PeisId, wire::RouteEntry> advert;
    // What it last heard from us, compactly (a name by its hash).
    boost::container::flat_map<PeisId, Told> told;
    bool toldAll = false;  // it got our whole table once
  };
  void advertChanged(PeisId from, PeisId id, std::uint8_t hops);

  PeisId self_;
  std::uint64_t incarnation_;
  std::string name_;
  std::map<PeisId, Route> routes_;
  std::map<PeisId, Neighbour> neighbours_;
  std::set<PeisId> dirty_;        // ids whose route recompute() must re-evaluate
  std::set<PeisId> advertDirty_;  // ids whose route changed since the last advert
  std::uint64_t collision_ = 0;
};

}  // namespace peis::net
