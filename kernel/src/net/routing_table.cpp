// RoutingTable: distance-vector routes with feasibility, seqno requests and
// leaves, as a pure table; see routing_table.h and docs/protocol.md §8.
#include "net/routing_table.h"

#include <algorithm>

namespace peis::net {

namespace {

std::size_t nameHash(const std::string& name) { return std::hash<std::string>{}(name); }

// How often the memory of departed PEIS is swept.
constexpr std::chrono::seconds kSweepEvery{1};
// How far above its own seqno a PEIS raises it when asked.
constexpr std::uint32_t kMaxSeqnoStep = 64;

}  // namespace

RoutingTable::RoutingTable(Config config) : config_(std::move(config)) { reset(config_.self); }

void RoutingTable::reset(PeisId newSelf) {
  config_.self = newSelf;
  ownSeqno_ = 0;
  routes_.clear();
  neighbours_.clear();
  feasibility_.clear();
  departed_.clear();
  asked_.clear();
  heldUntil_.clear();
  recheckAt_.clear();
  messages_.clear();
  dirty_.clear();
  advertDirty_.clear();
  collision_ = 0;
  routes_[newSelf] =
      Route{0, newSelf, config_.incarnation, ownSeqno_, config_.name, config_.tool, false};
}

// --- Inputs --------------------------------------------------------------------------

void RoutingTable::linkUp(const wire::Hello& peer) {
  const auto linked = neighbours_.find(peer.id);
  const bool replacesLink =
      linked != neighbours_.end() && linked->second.hello.incarnation == peer.incarnation;
  auto& n = neighbours_[peer.id];
  auto advert = std::move(n.advert);
  n = Neighbour{};  // a new link: its first Routes is the whole table again
  n.hello = peer;
  if (replacesLink) {
    // Until that whole table comes, the old link's advert stands: what was
    // reachable through `peer` still is (the frames lost with the old link
    // are sent again, or recovered by the subscriptions' renewals, §10, §12).
    n.advert = std::move(advert);
    n.advertOfReplacedLink = true;
  }
  markDirty(peer.id);
  for (const auto& [id, route] : routes_) {
    if (route.nextHop == peer.id && route.hops > 0) markDirty(id);
  }
}

void RoutingTable::linkDown(PeisId peer) {
  neighbours_.erase(peer);
  markDirty(peer);
  for (const auto& [id, route] : routes_) {
    if (route.nextHop == peer && route.hops > 0) markDirty(id);
  }
}

bool RoutingTable::departed(PeisId id, std::uint64_t incarnation) const {
  const auto d = departed_.find(id);
  return d != departed_.end() && incarnation <= d->second.incarnation;
}

// Small deltas are applied entry by entry; a big advert (a whole table, or a
// flood) is sorted and merged in one pass, so that n entries cost
// O(n log n) whatever their order (inserting them one by one into the
// sorted advert costs O(n) each: a 65,534-entry advert in descending order
// once took seconds).
constexpr std::size_t kMergeAbove = 64;

void RoutingTable::onRoutes(PeisId from, std::vector<wire::RouteEntry>& entries) {
  auto neighbour = neighbours_.find(from);
  if (neighbour == neighbours_.end()) return;
  if (neighbour->second.advertOfReplacedLink) {
    neighbour->second.advertOfReplacedLink = false;
    dropUnoffered(from, neighbour->second, entries);
  }
  if (entries.size() > kMergeAbove) return mergeEntries(from, neighbour->second, entries);
  for (auto& entry : entries) applyEntry(from, neighbour->second, entry);
}

void RoutingTable::dropUnoffered(PeisId from, Neighbour& neighbour,
                                 const std::vector<wire::RouteEntry>& whole) {
  std::vector<PeisId> offered;
  offered.reserve(whole.size());
  for (const auto& entry : whole) offered.push_back(entry.id);
  std::sort(offered.begin(), offered.end());
  auto& known = neighbour.advert;
  boost::container::flat_map<PeisId, wire::RouteEntry> kept;
  kept.reserve(known.size());
  for (auto& [id, entry] : known) {
    if (std::binary_search(offered.begin(), offered.end(), id)) {
      kept.emplace_hint(kept.end(), id, std::move(entry));
      continue;
    }
    entry.hops = kWithdrawn;  // withdrawn on the old link, its delta lost with it
    entryChanged(from, entry);
  }
  known = std::move(kept);
}

RoutingTable::EntryKind RoutingTable::kindOf(PeisId from, const wire::RouteEntry& entry) {
  if (entry.id == config_.self) {
    // Its own entry (0 hops) naming our id: another PEIS holds it.
    if (entry.hops == 0 && entry.incarnation != config_.incarnation) {
      collision_ = entry.incarnation;
    }
    return EntryKind::Ours;
  }
  if (entry.hops == kWithdrawn || departed(entry.id, entry.incarnation) ||
      (entry.hops == 0 && entry.id != from)) {  // only the sender itself is at 0 hops
    return EntryKind::Removes;
  }
  return EntryKind::Offer;
}

void RoutingTable::applyEntry(PeisId from, Neighbour& neighbour, wire::RouteEntry& entry) {
  auto& known = neighbour.advert;
  const auto id = entry.id;
  switch (kindOf(from, entry)) {
    case EntryKind::Ours:
      return;
    case EntryKind::Removes: {
      const auto old = known.find(id);
      if (old == known.end()) return;
      auto withdrawn = std::move(old->second);
      withdrawn.hops = kWithdrawn;
      known.erase(old);
      entryChanged(from, withdrawn);
      return;
    }
    case EntryKind::Offer:
      break;
  }
  if (known.size() >= config_.maxRoutes && !known.count(id)) {
    ++refused_;
    return;
  }
  entryChanged(from, entry);
  known.insert_or_assign(id, std::move(entry));
}

void RoutingTable::mergeEntries(PeisId from, Neighbour& neighbour,
                                std::vector<wire::RouteEntry>& entries) {
  // The last entry of an id wins, as when applied in order.
  std::stable_sort(entries.begin(), entries.end(),
                   [](const auto& a, const auto& b) { return a.id < b.id; });
  auto& known = neighbour.advert;
  std::vector<std::pair<PeisId, wire::RouteEntry>> merged;
  merged.reserve(std::min(known.size() + entries.size(), config_.maxRoutes + 1));
  std::size_t size = known.size();
  auto old = known.begin();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (i + 1 < entries.size() && entries[i + 1].id == entries[i].id) continue;
    auto& entry = entries[i];
    while (old != known.end() && old->first < entry.id) merged.push_back(std::move(*old++));
    const bool had = old != known.end() && old->first == entry.id;
    switch (kindOf(from, entry)) {
      case EntryKind::Ours:
        break;
      case EntryKind::Removes:
        if (had) {
          auto withdrawn = std::move(old->second);
          withdrawn.hops = kWithdrawn;
          ++old;
          --size;
          entryChanged(from, withdrawn);
        }
        continue;
      case EntryKind::Offer:
        if (!had && size >= config_.maxRoutes) {
          ++refused_;
          continue;
        }
        if (had) {
          ++old;
        } else {
          ++size;
        }
        entryChanged(from, entry);
        merged.emplace_back(entry.id, std::move(entry));
        continue;
    }
  }
  while (old != known.end()) merged.push_back(std::move(*old++));
  known = boost::container::flat_map<PeisId, wire::RouteEntry>(
      boost::container::ordered_unique_range, merged.begin(), merged.end());
}

// An advert entry from `from` changed: its id needs re-evaluating only if the
// entry could change its route (no route yet, a held one, the current next
// hop's or the neighbour's own entry, fewer hops, or a newer seqno).
void RoutingTable::entryChanged(PeisId from, const wire::RouteEntry& e) {
  const auto route = routes_.find(e.id);
  if (route == routes_.end() || route->second.held || route->second.nextHop == from ||
      e.id == from) {
    return markDirty(e.id);
  }
  if (e.hops == kWithdrawn) return;
  const auto& r = route->second;
  if (e.hops + 1 < r.hops || e.incarnation > r.incarnation ||
      (e.incarnation == r.incarnation && e.seqno > r.seqno)) {
    markDirty(e.id);
  }
}

bool RoutingTable::onLeave(PeisId from, const wire::Leave& leave, Time now) {
  if (leave.id == config_.self) return false;               // it is not us who left
  if (departed(leave.id, leave.incarnation)) return false;  // heard already
  // A linked PEIS says so itself, on its own link; and a PEIS nobody here
  // has a route to needs no memory (a flood of made-up Leaves costs nothing).
  if (neighbours_.count(leave.id) && from != leave.id) return false;
  if (!routes_.count(leave.id)) {
    bool offered = false;
    for (const auto& [peer, neighbour] : neighbours_)
      offered |= neighbour.advert.count(leave.id) != 0;
    if (!offered) return false;
  }
  Departed gone{leave.incarnation, now, {}};
  if (neighbours_.count(leave.id)) gone.ways.push_back(leave.id);
  if (const auto route = routes_.find(leave.id); route != routes_.end())
    gone.ways.push_back(route->second.nextHop);
  for (const auto& [peer, neighbour] : neighbours_)
    if (neighbour.advert.count(leave.id)) gone.ways.push_back(peer);
  departed_[leave.id] = std::move(gone);
  for (auto& [peer, neighbour] : neighbours_) {
    const auto entry = neighbour.advert.find(leave.id);
    if (entry != neighbour.advert.end() && entry->second.incarnation <= leave.incarnation) {
      neighbour.advert.erase(entry);
    }
  }
  markDirty(leave.id);
  return true;
}

void RoutingTable::onSeqnoRequest(PeisId from, const wire::SeqnoRequest& request, Time now) {
  if (request.id == config_.self) {
    // Nobody can have heard a seqno of ours above ownSeqno_: a request far
    // beyond it is made up (it would use up the seqnos, which never wrap).
    if (request.incarnation != config_.incarnation || request.seqno <= ownSeqno_ ||
        request.seqno > ownSeqno_ + kMaxSeqnoStep) {
      return;
    }
    ownSeqno_ = request.seqno;  // the new seqno reaches everybody with the next advert
    routes_[config_.self].seqno = ownSeqno_;
    advertDirty_.insert(config_.self);
    return;
  }
  const auto route = routes_.find(request.id);
  if (route == routes_.end()) return;
  const auto& r = route->second;
  if (!r.held && r.incarnation == request.incarnation && r.seqno >= request.seqno) return;
  if (r.nextHop == from || request.hopLimit <= 1) return;
  ask(request.id, request.incarnation, request.seqno, r.nextHop,
      static_cast<std::uint8_t>(request.hopLimit - 1), now, config_.holdFor / 8);
}

void RoutingTable::ask(PeisId id, std::uint64_t incarnation, std::uint32_t seqno, PeisId via,
                       std::uint8_t hopLimit, Time now, std::chrono::milliseconds quiet) {
  auto& asked = asked_[id];
  if (asked.seqno >= seqno && asked.at != Time{} && now - asked.at < quiet) return;
  asked = Asked{seqno, now};
  messages_.push_back(Message{via, wire::SeqnoRequest{id, incarnation, seqno, hopLimit}});
}

std::optional<std::uint64_t> RoutingTable::takeCollision() {
  if (collision_ == 0) return std::nullopt;
  const auto other = collision_;
  collision_ = 0;
  return other;
}

// --- Work ----------------------------------------------------------------------------

// Feasible (RFC 8966 §3.5.1): a newer incarnation or seqno than the best route
// we had, or that seqno with fewer hops than our own route had. Whatever a
// feasible neighbour offers cannot lead back through us.
bool RoutingTable::feasible(PeisId id, std::uint64_t incarnation, std::uint32_t seqno,
                            int theirHops) const {
  const auto fd = feasibility_.find(id);
  if (fd == feasibility_.end()) return true;
  const auto& f = fd->second;
  if (incarnation != f.incarnation) return incarnation > f.incarnation;
  if (seqno != f.seqno) return seqno > f.seqno;
  return theirHops < f.hops;
}

RoutingTable::Changes RoutingTable::recompute(Time now) {
  Changes changes;
  for (const auto& [id, until] : heldUntil_) {
    if (until <= now) markDirty(id);
  }
  for (const auto& [id, at] : recheckAt_) {
    if (at <= now) markDirty(id);
  }
  const auto dirty = std::move(dirty_);
  dirty_.clear();
  for (const PeisId id : dirty) evaluate(id, now, changes);
  // Forget, in time, what is known of PEIS that are gone.
  if (now - lastSweep_ >= kSweepEvery) {
    lastSweep_ = now;
    std::erase_if(feasibility_, [&](const auto& f) {
      return f.second.goneSince && now - *f.second.goneSince > config_.rememberFor;
    });
    std::erase_if(departed_,
                  [&](const auto& d) { return now - d.second.at > config_.rememberFor; });
    std::erase_if(asked_, [&](const auto& a) { return now - a.second.at > config_.rememberFor; });
  }
  return changes;
}

// Distance vector with feasibility: among the feasible offers, the newest
// incarnation, then the fewest hops; on a tie the current next hop is kept,
// else the lowest neighbour id. Without a feasible offer the route is held
// (see the header) on the best infeasible one, or dropped if there is none.
void RoutingTable::evaluate(PeisId id, Time now, Changes& changes) {
  if (id == config_.self) return;
  const auto old = routes_.find(id);
  const PeisId oldNextHop = old == routes_.end() ? 0 : old->second.nextHop;
  const auto fd = feasibility_.find(id);
  const Feasibility* f = fd == feasibility_.end() ? nullptr : &fd->second;
  Candidate best, bestHeld;
  auto consider = [&](const Candidate& c, bool isFeasible) {
    auto& b = isFeasible ? best : bestHeld;
    if (!b.name || c.incarnation > b.incarnation ||
        (c.incarnation == b.incarnation &&
         (c.hops < b.hops || (c.hops == b.hops && c.nextHop == oldNextHop)))) {
      b = c;
    }
  };
  // A linked PEIS is reached over its link, whatever others offer: its own
  // Hello says its incarnation (an offer of a "newer life" from another
  // PEIS would otherwise take its route away).
  const bool linked = neighbours_.count(id) != 0;
  for (const auto& [peer, n] : neighbours_) {
    if (linked && peer != id) continue;
    if (peer == id) {
      // The direct link: at 0 hops from its own end, always feasible.
      if (departed(id, n.hello.incarnation)) continue;
      std::uint32_t seqno = f && f->incarnation == n.hello.incarnation ? f->seqno : 0;
      const auto own = n.advert.find(id);
      if (own != n.advert.end() && own->second.incarnation == n.hello.incarnation) {
        seqno = std::max(seqno, own->second.seqno);
      }
      consider(Candidate{1, peer, n.hello.incarnation, seqno, &n.hello.name,
                         (n.hello.capabilities & wire::kCapabilityTool) != 0},
               true);
      continue;
    }
    const auto entry = n.advert.find(id);
    if (entry == n.advert.end()) continue;
    const auto& e = entry->second;
    if (e.hops + 1 > kMaxHops) continue;                // the hop limit
    if (f && e.incarnation < f->incarnation) continue;  // an earlier life of it
    consider(Candidate{e.hops + 1, peer, e.incarnation, e.seqno, &e.name,
                       (e.flags & wire::kRouteFlagTool) != 0},
             feasible(id, e.incarnation, e.seqno, e.hops));
  }
  if (best.name || !bestHeld.name) recheckAt_.erase(id);
  if (best.name) {
    heldUntil_.erase(id);
    if (old == routes_.end() && best.nextHop != id && routes_.size() > config_.maxRoutes) {
      ++refused_;  // the table is full; a linked PEIS still enters
      return;
    }
    setRoute(
        id,
        Route{best.hops, best.nextHop, best.incarnation, best.seqno, *best.name, best.tool, false},
        now, changes);
    auto& feas = feasibility_[id];
    if (!f || best.incarnation != feas.incarnation || best.seqno > feas.seqno) {
      feas = Feasibility{best.incarnation, best.seqno, best.hops, std::nullopt};
    } else {
      feas.hops = std::min(feas.hops, best.hops);
      feas.goneSince.reset();
    }
    return;
  }
  if (!bestHeld.name) {
    if (old != routes_.end()) dropRoute(id, now, changes);
    return;
  }
  // Only infeasible offers: they may be stale echoes of our own old route
  // (a loop), or a real path that the feasibility condition cannot tell
  // apart. The destination's next seqno will say: ask it.
  const std::uint32_t want = (f ? f->seqno : bestHeld.seqno) + 1;
  ask(id, bestHeld.incarnation, want, bestHeld.nextHop, kMaxHops, now, config_.holdFor);
  if (old == routes_.end()) {
    // Nothing to hold: the route comes with the new seqno. Until then, or
    // until the offers are withdrawn, ask again every hold time (a request
    // lost on a route that changed, a partition that healed).
    recheckAt_[id] = now + config_.holdFor;
    return;
  }
  auto until = heldUntil_.find(id);
  if (until == heldUntil_.end()) until = heldUntil_.emplace(id, now + config_.holdFor).first;
  if (now >= until->second) {
    dropRoute(id, now, changes);
    return;
  }
  setRoute(id,
           Route{bestHeld.hops, bestHeld.nextHop, bestHeld.incarnation, bestHeld.seqno,
                 *bestHeld.name, bestHeld.tool, true},
           now, changes);
}

void RoutingTable::setRoute(PeisId id, Route route, Time now, Changes& changes) {
  const auto old = routes_.find(id);
  if (old == routes_.end()) {
    route.nextHopSince = now;
    routes_.emplace(id, std::move(route));
    changes.up.push_back(id);
    changes.topology = true;
    advertDirty_.insert(id);
    return;
  }
  auto& r = old->second;
  if (r == route) return;
  if (r.incarnation != route.incarnation) changes.up.push_back(id);
  if (r.hops != route.hops || r.nextHop != route.nextHop || r.name != route.name ||
      r.tool != route.tool || r.incarnation != route.incarnation) {
    changes.topology = true;
  }
  if (r.nextHop != route.nextHop) {
    route.previousNextHop = r.nextHop;
    route.nextHopSince = now;
  } else {
    route.previousNextHop = r.previousNextHop;
    route.nextHopSince = r.nextHopSince;
  }
  r = std::move(route);
  advertDirty_.insert(id);
}

void RoutingTable::dropRoute(PeisId id, Time now, Changes& changes) {
  routes_.erase(id);
  heldUntil_.erase(id);
  changes.down.push_back(id);
  changes.topology = true;
  advertDirty_.insert(id);
  if (auto f = feasibility_.find(id); f != feasibility_.end()) f->second.goneSince = now;
}

std::optional<RoutingTable::Time> RoutingTable::nextDeadline() const {
  std::optional<Time> first;
  for (const auto* times : {&heldUntil_, &recheckAt_}) {
    for (const auto& [id, until] : *times) {
      if (!first || until < *first) first = until;
    }
  }
  return first;
}

std::vector<RoutingTable::Message> RoutingTable::takeMessages() {
  std::vector<Message> out;
  out.swap(messages_);
  return out;
}

// --- Adverts -------------------------------------------------------------------------

RoutingTable::Told RoutingTable::toldOf(const wire::RouteEntry& e) {
  return Told{e.incarnation, nameHash(e.name), e.seqno, e.hops, e.flags};
}

// What `neighbour` may be told of our route to `id`: nothing for a held
// route, a route through it (split horizon) or, from a tool, any route but
// its own.
std::optional<wire::RouteEntry> RoutingTable::entryFor(PeisId neighbour, PeisId id) const {
  const auto route = routes_.find(id);
  if (route == routes_.end()) return std::nullopt;
  const auto& r = route->second;
  if (r.held || (r.hops > 0 && (r.nextHop == neighbour || config_.tool))) return std::nullopt;
  return wire::RouteEntry{id,
                          static_cast<std::uint8_t>(r.hops),
                          static_cast<std::uint8_t>(r.tool ? wire::kRouteFlagTool : 0),
                          r.incarnation,
                          r.seqno,
                          r.name};
}

wire::Routes RoutingTable::fullAdvert(PeisId peer) {
  wire::Routes all;
  auto neighbour = neighbours_.find(peer);
  if (neighbour == neighbours_.end()) return all;
  auto& told = neighbour->second.told;
  told.clear();
  told.reserve(routes_.size());
  neighbour->second.toldAll = true;
  for (const auto& [id, route] : routes_) {
    auto entry = entryFor(peer, id);
    if (!entry) continue;
    told.emplace_hint(told.end(), id, toldOf(*entry));
    all.entries.push_back(std::move(*entry));
  }
  return all;
}

// Tells each neighbour what changed in the routes it should know: only the
// ids whose route changed since the last advert are looked at.
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
    // What the neighbour is told now, in id order: merged into `told` in
    // one pass (one insertion at a time would cost O(n) each).
    std::vector<std::pair<PeisId, std::optional<Told>>> updates;
    for (const PeisId id : changed) {
      auto entry = entryFor(peer, id);
      const auto t = told.find(id);
      if (!entry) {
        if (t == told.end()) continue;
        delta.entries.push_back(wire::RouteEntry{id, kWithdrawn, 0, 0, 0, ""});
        updates.emplace_back(id, std::nullopt);
        continue;
      }
      const auto now = toldOf(*entry);
      if (t != told.end() && t->second == now) continue;
      updates.emplace_back(id, now);
      delta.entries.push_back(std::move(*entry));
    }
    mergeTold(told, updates);
    if (!delta.entries.empty()) out.emplace_back(peer, std::move(delta));
  }
  return out;
}

void RoutingTable::mergeTold(boost::container::flat_map<PeisId, Told>& told,
                             const std::vector<std::pair<PeisId, std::optional<Told>>>& updates) {
  if (updates.size() <= kMergeAbove) {
    for (const auto& [id, now] : updates) {
      if (now) {
        told.insert_or_assign(id, *now);
      } else {
        told.erase(id);
      }
    }
    return;
  }
  std::vector<std::pair<PeisId, Told>> merged;
  merged.reserve(told.size() + updates.size());
  auto old = told.begin();
  for (const auto& [id, now] : updates) {  // ascending ids
    while (old != told.end() && old->first < id) merged.push_back(*old++);
    if (old != told.end() && old->first == id) ++old;
    if (now) merged.emplace_back(id, *now);
  }
  merged.insert(merged.end(), old, told.end());
  told = boost::container::flat_map<PeisId, Told>(boost::container::ordered_unique_range,
                                                  merged.begin(), merged.end());
}

std::optional<wire::Routes> RoutingTable::tellNow(PeisId peer, PeisId id) {
  auto neighbour = neighbours_.find(peer);
  if (neighbour == neighbours_.end() || !neighbour->second.toldAll) return std::nullopt;
  auto entry = entryFor(peer, id);
  if (!entry) return std::nullopt;
  // Told already, unless what it was told is older than the route now (a
  // shorter route since: the neighbour would take the frame for spoofed).
  const auto now = toldOf(*entry);
  const auto told = neighbour->second.told.find(id);
  if (told != neighbour->second.told.end() && told->second == now) return std::nullopt;
  neighbour->second.told.insert_or_assign(id, now);
  wire::Routes one;
  one.entries.push_back(std::move(*entry));
  return one;
}

// --- Queries ---------------------------------------------------------------------

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

bool RoutingTable::mayRelay(PeisId neighbour, PeisId id, Time now,
                            std::chrono::milliseconds grace) const {
  const auto route = routes_.find(id);
  if (route == routes_.end()) return true;
  const auto& r = route->second;
  if (r.nextHop == neighbour) return true;
  if (r.previousNextHop == neighbour && now - r.nextHopSince < grace) return true;
  const auto n = neighbours_.find(neighbour);
  if (n == neighbours_.end()) return false;
  const auto offer = n->second.advert.find(id);
  if (neighbours_.count(id)) {
    // A linked PEIS: over its own link, but for `grace` after the link came
    // up, frames it sent before through a neighbour that offers a route to
    // it may still arrive that way.
    return now - r.nextHopSince < grace && offer != n->second.advert.end();
  }
  return offer != n->second.advert.end() && offer->second.hops + 1 <= r.hops;
}

bool RoutingTable::sentBeforeLeaving(PeisId neighbour, PeisId id, Time now,
                                     std::chrono::milliseconds grace) const {
  const auto d = departed_.find(id);
  if (d == departed_.end() || now - d->second.at >= grace) return false;
  const auto& ways = d->second.ways;
  return std::find(ways.begin(), ways.end(), neighbour) != ways.end();
}

bool RoutingTable::hasAlternative(PeisId peer) const {
  for (const auto& [id, neighbour] : neighbours_) {
    if (id != peer && neighbour.advert.count(peer)) return true;
  }
  return false;
}

}  // namespace peis::net
