// RoutingTable: distance-vector routes as a pure table; see routing_table.h.
#include "net/routing_table.h"

namespace peis::net {

RoutingTable::RoutingTable(PeisId self, std::uint64_t incarnation, std::string name)
    : self_(self), incarnation_(incarnation), name_(std::move(name)) {
  routes_[self_] = Route{0, self_, incarnation_, name_};
}

void RoutingTable::reset(PeisId newSelf) {
  self_ = newSelf;
  routes_.clear();
  neighbours_.clear();
  dirty_.clear();
  advertDirty_.clear();
  collision_ = 0;
  routes_[self_] = Route{0, self_, incarnation_, name_};
}

void RoutingTable::linkUp(const wire::Hello& peer) {
  auto& n = neighbours_[peer.id];
  n = Neighbour{};  // a new link: its first Routes is the whole table again
  n.hello = peer;
  dirty_.insert(peer.id);
  for (const auto& [id, route] : routes_) {
    if (route.nextHop == peer.id && route.hops > 0) dirty_.insert(id);
  }
}

void RoutingTable::linkDown(PeisId peer) {
  neighbours_.erase(peer);
  dirty_.insert(peer);
  for (const auto& [id, route] : routes_) {
    if (route.nextHop == peer && route.hops > 0) dirty_.insert(id);
  }
}

bool RoutingTable::onRoutes(PeisId from, std::vector<wire::RouteEntry>& entries) {
  auto neighbour = neighbours_.find(from);
  if (neighbour == neighbours_.end()) return false;
  auto& known = neighbour->second.advert;
  for (auto& entry : entries) {
    if (entry.id == self_) {
      // Its own entry (0 hops) naming our id: another PEIS holds it.
      if (entry.hops == 0 && entry.incarnation != incarnation_) collision_ = entry.incarnation;
      continue;
    }
    const auto id = entry.id;
    const auto hops = entry.hops;
    if (hops == kWithdrawn) {
      if (known.erase(id) == 0) continue;
    } else {
      known[id] = std::move(entry);
    }
    advertChanged(from, id, hops);
  }
  return hasWork();
}

std::optional<std::uint64_t> RoutingTable::takeCollision() {
  if (collision_ == 0) return std::nullopt;
  const auto other = collision_;
  collision_ = 0;
  return other;
}

// An advert entry from `from` changed: its id needs re-evaluating only if
// the entry could change its route (no route yet, a better one, or one
// from the current next hop).
void RoutingTable::advertChanged(PeisId from, PeisId id, std::uint8_t hops) {
  const auto route = routes_.find(id);
  if (route == routes_.end() || route->second.nextHop == from ||
      (hops != kWithdrawn && hops + 1 < route->second.hops)) {
    dirty_.insert(id);
  }
}

// Distance vector: the shortest route over the links and their adverts wins;
// on a tie the current next hop is kept, else the lowest neighbour id
// offering it. Only the dirty ids are evaluated: every other route is
// unchanged, since none of its candidates changed in a way that could move it.
RoutingTable::Changes RoutingTable::recompute() {
  Changes changes;
  const auto dirty = std::move(dirty_);
  dirty_.clear();
  for (const PeisId id : dirty) {
    if (id == self_) continue;
    const auto old = routes_.find(id);
    const PeisId oldNextHop = old == routes_.end() ? 0 : old->second.nextHop;
    int bestHops = kMaxHops + 1;
    PeisId bestNextHop = 0;
    std::uint64_t bestIncarnation = 0;
    const std::string* bestName = nullptr;
    auto offer = [&](int hops, PeisId nextHop, std::uint64_t incarnation, const std::string& name) {
      if (hops > bestHops) return;
      if (hops < bestHops || nextHop == oldNextHop) {
        bestHops = hops;
        bestNextHop = nextHop;
        bestIncarnation = incarnation;
        bestName = &name;
      }
    };
    for (const auto& [peer, n] : neighbours_) {
      if (peer == id) offer(1, id, n.hello.incarnation, n.hello.name);
      const auto entry = n.advert.find(id);
      if (entry == n.advert.end() || entry->second.hops + 1 > kMaxHops) continue;
      offer(entry->second.hops + 1, peer, entry->second.incarnation, entry->second.name);
    }
    if (!bestName) {
      if (old == routes_.end()) continue;
      routes_.erase(old);
      advertDirty_.insert(id);
      changes.down.push_back(id);
      changes.changed = true;
      continue;
    }
    Route best{bestHops, bestNextHop, bestIncarnation, *bestName};
    if (old == routes_.end()) {
      routes_.emplace(id, std::move(best));
      changes.up.push_back(id);
    } else if (old->second != best) {
      if (old->second.incarnation != best.incarnation) changes.up.push_back(id);
      old->second = std::move(best);
    } else {
      continue;
    }
    advertDirty_.insert(id);
    changes.changed = true;
  }
  return changes;
}

wire::Routes RoutingTable::fullAdvert(PeisId peer) {
  wire::Routes all;
  auto neighbour = neighbours_.find(peer);
  if (neighbour == neighbours_.end()) return all;
  auto& told = neighbour->second.told;
  told.clear();
  neighbour->second.toldAll = true;
  for (const auto& [id, route] : routes_) {
    if (route.hops > 0 && route.nextHop == peer) continue;  // split horizon
    wire::RouteEntry entry{id, static_cast<std::uint8_t>(route.hops), route.incarnation,
                           route.name};
    told.emplace_hint(told.end(), id, Told::of(entry));
    all.entries.push_back(std::move(entry));
  }
  return all;
}

// Tells each neighbour what changed in the routes it should know (split
// horizon: never a route back through itself): only the ids whose route
// changed since the last advert are looked at.
std::vector<std::pair<PeisId, wire::Routes>> RoutingTable::advertise() {
  std::vector<std::pair<PeisId, wire::Routes>> out;
  if (advertDirty_.empty()) return out;
  const auto changed = std::move(advertDirty_);
  advertDirty_.clear();
  for (auto& [peer, neighbour] : neighbours_) {
    if (!neighbour.toldAll) {
      auto all = fullAdvert(peer);
      if (!all.entries.empty()) out.emplace_back(peer, std::move(all));
      continue;
    }
    auto& told = neighbour.told;
    wire::Routes delta;
    for (const PeisId id : changed) {
      const auto r = routes_.find(id);
      const bool tell = r != routes_.end() && !(r->second.hops > 0 && r->second.nextHop == peer);
      const auto t = told.find(id);
      if (!tell) {
        if (t == told.end()) continue;
        delta.entries.push_back(wire::RouteEntry{id, kWithdrawn, 0, ""});
        told.erase(t);
        continue;
      }
      const auto& route = r->second;
      if (t != told.end() && t->second.hops == route.hops &&
          t->second.incarnation == route.incarnation &&
          t->second.nameHash == Told::hash(route.name)) {
        continue;
      }
      wire::RouteEntry entry{id, static_cast<std::uint8_t>(route.hops), route.incarnation,
                             route.name};
      if (t == told.end()) {
        told.emplace(id, Told::of(entry));
      } else {
        t->second = Told::of(entry);
      }
      delta.entries.push_back(std::move(entry));
    }
    if (!delta.entries.empty()) out.emplace_back(peer, std::move(delta));
  }
  return out;
}

std::optional<wire::Routes> RoutingTable::tellNow(PeisId peer, PeisId id) {
  auto neighbour = neighbours_.find(peer);
  if (neighbour == neighbours_.end() || !neighbour->second.toldAll ||
      neighbour->second.told.count(id)) {
    return std::nullopt;
  }
  const auto route = routes_.find(id);
  if (route == routes_.end()) return std::nullopt;
  const auto& r = route->second;
  if (r.hops > 0 && r.nextHop == peer) return std::nullopt;  // split horizon
  wire::RouteEntry entry{id, static_cast<std::uint8_t>(r.hops), r.incarnation, r.name};
  neighbour->second.told.insert_or_assign(id, Told::of(entry));
  wire::Routes one;
  one.entries.push_back(std::move(entry));
  return one;
}

const RoutingTable::Route* RoutingTable::find(PeisId id) const {
  const auto it = routes_.find(id);
  return it == routes_.end() ? nullptr : &it->second;
}

PeisId RoutingTable::nextHop(PeisId id) const {
  const auto it = routes_.find(id);
  if (it == routes_.end() || it->second.hops == 0) return 0;
  return it->second.nextHop;
}

bool RoutingTable::advertises(PeisId peer, PeisId id) const {
  const auto neighbour = neighbours_.find(peer);
  return neighbour != neighbours_.end() && neighbour->second.advert.count(id) != 0;
}

bool RoutingTable::hasAlternative(PeisId peer) const {
  for (const auto& [id, neighbour] : neighbours_) {
    if (id != peer && neighbour.advert.count(peer)) return true;
  }
  return false;
}

}  // namespace peis::net
