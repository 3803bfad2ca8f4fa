// RoutingTable: the distance-vector routing of one PEIS as a pure table, with
// no sockets and no timers of its own (docs/protocol.md §8). It is told which
// PEIS are linked, what each linked PEIS advertises, the leaves and seqno
// requests that arrive, and the time; it answers with the route to every
// reachable PEIS, the PEIS that became reachable or unreachable, and the
// messages each neighbour must be sent: `Routes` deltas (split horizon) and
// `SeqnoRequest`s. Unit-tested on its own, count-to-infinity and leaves
// included (tests/kernel/routing_table_test.cpp).
//
// Routes never count to infinity: as in Babel (RFC 8966), every PEIS stamps
// its own route with a sequence number, and a PEIS takes a route from a
// neighbour only if it is *feasible*: of a newer incarnation or seqno than
// the best it has had, or of that seqno with fewer hops than its own route
// had (its feasibility distance). A stale route circulating in a loop has
// the old seqno and more hops, so it is never taken. A PEIS that loses its
// route and sees only infeasible ones keeps the best of them for a moment
// (held: used for forwarding, withdrawn from its adverts) and asks the
// destination for a newer seqno; if none comes within the hold time, the
// route is dropped. A PEIS that quits cleanly floods a `Leave`, which
// removes it everywhere at once.
#pragma once

#include <boost/container/flat_map.hpp>
#include <chrono>
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
  using Clock = std::chrono::steady_clock;
  using Time = Clock::time_point;
  static constexpr int kMaxHops = 32;
  static constexpr std::uint8_t kWithdrawn = 255;  // a route entry that is no longer valid

  struct Config {
    PeisId self = 0;
    std::uint64_t incarnation = 0;
    std::string name;
    bool tool = false;  // a tool PEIS advertises only itself: it never relays
    // How long a route with only infeasible successors is held while a
    // newer seqno is asked for.
    std::chrono::milliseconds holdFor{1000};
    // How long what is known of a departed PEIS (its feasibility distance,
    // its leave) is remembered: stale adverts of it are refused meanwhile.
    std::chrono::milliseconds rememberFor{60000};
    // PEIS in the table besides this one, and route entries one neighbour
    // may advertise; entries beyond are refused and counted (a directly
    // linked PEIS always enters: links are capped on their own).
    std::size_t maxRoutes = 4096;
  };

  struct Route {
    int hops = 0;  // 0: this PEIS
    PeisId nextHop = 0;
    std::uint64_t incarnation = 0;
    std::uint32_t seqno = 0;
    std::string name;
    bool tool = false;
    bool held = false;  // no feasible successor: kept, withdrawn, a newer seqno asked
    // When the next hop last changed, and the one before (not part of ==).
    Time nextHopSince{};
    PeisId previousNextHop = 0;
    bool operator==(const Route& o) const {
      return hops == o.hops && nextHop == o.nextHop && incarnation == o.incarnation &&
             seqno == o.seqno && name == o.name && tool == o.tool && held == o.held;
    }
  };
  // What one recompute changed (for the Network's events).
  struct Changes {
    std::vector<PeisId> down;  // left the table
    std::vector<PeisId> up;    // entered it, or came back with a new incarnation
    bool topology = false;     // a route's hops, next hop, name or flags moved
  };
  // A link message for one neighbour.
  struct Message {
    PeisId to = 0;
    wire::LinkMessage message;
  };

  explicit RoutingTable(Config config);

  PeisId self() const { return config_.self; }
  // This PEIS took a new id: every route, advert and memory is forgotten.
  void reset(PeisId newSelf);

  // --- Inputs ------------------------------------------------------------------
  // A link to `peer` was established (its Hello). A link that replaces one
  // to the same life of `peer` (a duplicate link, docs/protocol.md §7) keeps
  // what the old link advertised until the new link's first `Routes`, the
  // peer's whole table, replaces it: the routes through `peer` stay up
  // meanwhile rather than go down and up again.
  void linkUp(const wire::Hello& peer);
  // The last link to `peer` closed.
  void linkDown(PeisId peer);
  // A `Routes` message from linked PEIS `from` (applied as a delta).
  void onRoutes(PeisId from, std::vector<wire::RouteEntry>& entries);
  // A `Leave` from linked PEIS `from`. True when it is news: pass it on to
  // every other neighbour.
  bool onLeave(PeisId from, const wire::Leave& leave, Time now);
  void onSeqnoRequest(PeisId from, const wire::SeqnoRequest& request, Time now);
  // Another PEIS advertised our id at 0 hops with this incarnation: an id
  // collision (docs/protocol.md §7). Cleared when taken.
  std::optional<std::uint64_t> takeCollision();

  // --- Work ---------------------------------------------------------------------------
  // Whether recompute() has work (inputs changed candidates, a collision).
  bool hasWork() const { return !dirty_.empty() || collision_ != 0; }
  // Re-evaluates the routes whose candidates changed, drops held routes
  // whose time is up, and forgets departed PEIS remembered long enough.
  Changes recompute(Time now);
  // When recompute() must run next (a held route's time is up, or a seqno
  // is to be asked again), if ever.
  std::optional<Time> nextDeadline() const;
  // Seqno requests to send now.
  std::vector<Message> takeMessages();

  // --- Adverts ---------------------------------------------------------------------------
  // Whether advertise() has something to say.
  bool hasAdverts() const { return !advertDirty_.empty(); }
  // The whole table for a new neighbour (less the routes through it); from
  // then on it gets deltas.
  wire::Routes fullAdvert(PeisId neighbour);
  // The deltas each neighbour needs since its last advert.
  std::vector<std::pair<PeisId, wire::Routes>> advertise();
  // Our route to `id` for `neighbour` now, if it has had its full advert,
  // was not told this route yet (none, or an older one) and may be told it
  // (a relayed frame must not arrive before the route to its source, §8).
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
  // Whether linked PEIS `neighbour` may relay frames from `id`: it is the
  // next hop of our route to `id`, or was until `grace` ago, or (`id` not
  // linked) offers a route to it at least as short; true too for an `id`
  // without a route yet (its frames wait for it, then are asked again).
  bool mayRelay(PeisId neighbour, PeisId id, Time now, std::chrono::milliseconds grace) const;
  // Whether a frame from `id`, which sent a Leave less than `grace` ago,
  // may still arrive over linked PEIS `neighbour`: a frame it sent before
  // leaving, overtaken by its Leave on another way (the last value it
  // wrote to a subscriber further away, say).
  bool sentBeforeLeaving(PeisId neighbour, PeisId id, Time now,
                         std::chrono::milliseconds grace) const;
  // Route entries refused so far (over Config::maxRoutes).
  std::uint64_t refused() const { return refused_; }
  const std::map<PeisId, Route>& routes() const { return routes_; }
  std::uint32_t ownSeqno() const { return ownSeqno_; }

 private:
  // What a neighbour last heard from us about one route (for deltas).
  struct Told {  // fields ordered for size: 24 bytes, 32 with its key
    std::uint64_t incarnation = 0;
    std::size_t nameHash = 0;
    std::uint32_t seqno = 0;
    std::uint8_t hops = 0;
    std::uint8_t flags = 0;
    bool operator==(const Told&) const = default;
  };
  struct Neighbour {
    wire::Hello hello;
    // What it told us it can reach (applied as deltas).
    boost::container::flat_map<PeisId, wire::RouteEntry> advert;
    // What it last heard from us, compactly (a name by its hash).
    boost::container::flat_map<PeisId, Told> told;
    bool toldAll = false;  // it got our whole table once
    // The advert came over a link since replaced by another to the same
    // PEIS: the next `Routes` (the new link's first) is its whole table.
    bool advertOfReplacedLink = false;
  };
  // The best route this PEIS has had to a PEIS, for the feasibility
  // condition, kept a while after the route is gone.
  struct Feasibility {
    std::uint64_t incarnation = 0;
    std::uint32_t seqno = 0;
    int hops = 0;
    std::optional<Time> goneSince;
  };
  struct Departed {
    std::uint64_t incarnation = 0;
    Time at;
    // The neighbours its frames could come over when it left: its own link,
    // our next hop to it, and those that offered a route to it.
    std::vector<PeisId> ways;
  };
  struct Asked {
    std::uint32_t seqno = 0;
    Time at;
  };
  struct Candidate {
    int hops = kMaxHops + 1;
    PeisId nextHop = 0;
    std::uint64_t incarnation = 0;
    std::uint32_t seqno = 0;
    const std::string* name = nullptr;
    bool tool = false;
  };

  void markDirty(PeisId id) { dirty_.insert(id); }
  // Applies one entry of a neighbour's advert to `known` (the per-entry
  // path, for small deltas), or many at once in one sorted merge.
  void applyEntry(PeisId from, Neighbour& neighbour, wire::RouteEntry& entry);
  void mergeEntries(PeisId from, Neighbour& neighbour, std::vector<wire::RouteEntry>& entries);
  // Withdraws what `neighbour` advertised over its replaced link and does not
  // offer in `whole`, the new link's whole table.
  void dropUnoffered(PeisId from, Neighbour& neighbour, const std::vector<wire::RouteEntry>& whole);
  // What an entry from `from` does: it is ours, it removes the id, or it
  // is an offer.
  enum class EntryKind { Ours, Removes, Offer };
  EntryKind kindOf(PeisId from, const wire::RouteEntry& entry);
  void entryChanged(PeisId from, const wire::RouteEntry& entry);
  bool departed(PeisId id, std::uint64_t incarnation) const;
  bool feasible(PeisId id, std::uint64_t incarnation, std::uint32_t seqno, int theirHops) const;
  // Evaluates one destination; fills `changes`.
  void evaluate(PeisId id, Time now, Changes& changes);
  void setRoute(PeisId id, Route route, Time now, Changes& changes);
  void dropRoute(PeisId id, Time now, Changes& changes);
  // Asks `id` (through `via`) for a seqno of at least `seqno`, unless the
  // same was asked less than `quiet` ago.
  void ask(PeisId id, std::uint64_t incarnation, std::uint32_t seqno, PeisId via,
           std::uint8_t hopLimit, Time now, std::chrono::milliseconds quiet);
  std::optional<wire::RouteEntry> entryFor(PeisId neighbour, PeisId id) const;
  static Told toldOf(const wire::RouteEntry& entry);
  // Applies updates in ascending id order (nullopt: forgotten) to `told`.
  static void mergeTold(boost::container::flat_map<PeisId, Told>& told,
                        const std::vector<std::pair<PeisId, std::optional<Told>>>& updates);

  Config config_;
  std::uint32_t ownSeqno_ = 0;
  std::map<PeisId, Route> routes_;
  std::map<PeisId, Neighbour> neighbours_;
  std::map<PeisId, Feasibility> feasibility_;
  std::map<PeisId, Departed> departed_;  // PEIS that sent a Leave
  std::map<PeisId, Asked> asked_;        // seqno requests sent or passed on
  std::map<PeisId, Time> heldUntil_;
  std::map<PeisId, Time> recheckAt_;  // no route, only infeasible offers: ask again then
  std::vector<Message> messages_;
  std::set<PeisId> dirty_;        // ids whose route recompute() must re-evaluate
  std::set<PeisId> advertDirty_;  // ids whose route changed since the last advert
  std::uint64_t collision_ = 0;
  std::uint64_t refused_ = 0;
  Time lastSweep_{};
};

}  // namespace peis::net
